"""The runtime's and the emitter's own configs reject bad values (the settings embed them as they are)."""

from __future__ import annotations

from typing import Any

import pytest

from pipeline.emitter.config import EmitterConfig, parse_endpoint
from pipeline.runtime.config import RuntimeConfig
from pipeline.sources.grouper import GrouperConfig


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"target_fps": 0.0}, "target_fps"),
        ({"video_pace_fps": -1.0}, "video_pace_fps"),
        ({"ring_slots": 1}, "ring_slots"),
        ({"start_method": "thread"}, "start_method"),
        ({"capture_nice": 20}, "capture_nice"),
        ({"stall_after_s": 0.0}, "stall_after_s"),
    ],
)
def test_bad_values_rejected(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        RuntimeConfig(**kwargs)


def test_bad_osc_destination_rejected() -> None:
    with pytest.raises(ValueError, match="must be HOST:PORT"):
        EmitterConfig(osc=("no-port",))
    both = EmitterConfig(osc=("127.0.0.1:9000", "[::1]:9001"))
    assert both.osc_endpoints == [("127.0.0.1", 9000), ("::1", 9001)]


@pytest.mark.parametrize(("text", "match"), [("nohost", "HOST:PORT"), (":7000", "HOST:PORT"),
                                             ("h:x", "not a number"), ("h:0", "1-65535")])
def test_one_parser_of_destinations(text: str, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        parse_endpoint(text)
    assert parse_endpoint("ws1.local:7000") == ("ws1.local", 7000)


def test_grouper_rejects_negative_times() -> None:
    with pytest.raises(ValueError, match="max_wait_s"):
        GrouperConfig(max_wait_s=-0.1)
