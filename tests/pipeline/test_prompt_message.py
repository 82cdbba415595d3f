"""The additive protocol v1 ``prompt`` message: built, validated, refused when malformed."""

from __future__ import annotations

import pytest

from pipeline.emitter.protocol import encode, prompt_message, validate_datagram
from pipeline.errors import InputError


def test_a_prompt_message_round_trips_through_the_validator() -> None:
    msg = prompt_message("Step forward on the spot", "forward", 3.456, 7, 1_796_000_000.25)
    assert msg == {
        "v": 1,
        "type": "prompt",
        "seq": 7,
        "ts": 1_796_000_000.25,
        "text": "Step forward on the spot",
        "label": "forward",
        "remaining_s": 3.46,
    }
    assert validate_datagram(encode(msg)) == msg


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"label": "jump"}, "label: expected one of"),
        ({"text": ""}, "text: expected a string"),
        ({"text": 5}, "text: expected a string"),
        ({"remaining_s": -1}, "remaining_s: expected a number >= 0"),
        ({"remaining_s": "3"}, "remaining_s: expected a finite number"),
        ({"extra": 1}, "prompt: unknown keys"),
    ],
)
def test_malformed_prompts_are_refused(change: dict, match: str) -> None:
    msg = prompt_message("Stand still", "still", 2.0, 0, 1_796_000_000.0) | change
    with pytest.raises(InputError, match=match):
        validate_datagram(msg)


def test_a_prompt_missing_a_key_is_refused() -> None:
    msg = prompt_message("Stand still", "still", 2.0, 0, 1_796_000_000.0)
    del msg["remaining_s"]
    with pytest.raises(InputError, match=r"prompt: missing keys \['remaining_s'\]"):
        validate_datagram(msg)
