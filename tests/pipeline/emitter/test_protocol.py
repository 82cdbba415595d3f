"""Protocol v1 datagrams and their validator."""

from __future__ import annotations

import json
from typing import Any

import pytest

from pipeline.emitter import (
    LocomotionCommand,
    encode,
    heartbeat_message,
    locomotion_message,
    validate_datagram,
)
from pipeline.errors import InputError

CMD = LocomotionCommand(3, "left", 0.8, -45.5, 0.9, (0.1, -0.2, 0.0), 100.0)


def good_locomotion() -> dict[str, Any]:
    return locomotion_message(CMD, 7, 1_700_000_000.25)


def test_locomotion_round_trip() -> None:
    data = encode(good_locomotion())
    msg = validate_datagram(data)
    assert msg == json.loads(data.decode("utf-8"))
    assert set(msg) == {"v", "type", "seq", "ts", "user_id", "action", "confidence", "yaw_deg",
                        "speed_mps", "position_m"}
    assert (msg["type"], msg["seq"], msg["user_id"], msg["action"]) == ("locomotion", 7, 3, "left")


def test_heartbeat_round_trip() -> None:
    msg = validate_datagram(encode(heartbeat_message("running", 0, 1_700_000_000.0)))
    assert msg == {"v": 1, "type": "heartbeat", "seq": 0, "ts": 1_700_000_000.0, "state": "running"}


def test_non_finite_values_never_reach_the_wire() -> None:
    cmd = LocomotionCommand(1, "still", float("nan"), float("inf"), float("nan"), (float("nan"), 0, 0), 1.0)
    msg = validate_datagram(encode(locomotion_message(cmd, 0, 1.0)))
    assert msg["confidence"] == 0.0 and msg["yaw_deg"] == 0.0 and msg["position_m"][0] == 0.0


def _mut(**changes: Any) -> dict[str, Any]:
    msg = good_locomotion()
    for k, v in changes.items():
        if v is _DROP:
            msg.pop(k)
        else:
            msg[k] = v
    return msg


_DROP = object()


@pytest.mark.parametrize(
    ("data", "match"),
    [
        (b"\xff\xfe", "not UTF-8 JSON"),
        (b"{not json", "not UTF-8 JSON"),
        (b"[1, 2]", "expected a JSON object"),
        (_mut(v=2), "v: expected 1"),
        (_mut(type="teleport"), "type: expected"),
        (_mut(seq=_DROP), "missing keys \\['seq'\\]"),
        (_mut(extra=1), "unknown keys \\['extra'\\]"),
        (_mut(seq=-1), "seq: expected an integer >= 0"),
        (_mut(seq=1.5), "seq: expected an integer"),
        (_mut(seq=True), "seq: expected an integer"),
        (_mut(ts=0), "ts: expected Unix seconds"),
        (_mut(ts="now"), "ts: expected a finite number"),
        (_mut(user_id=-3), "user_id: expected an integer >= 0"),
        (_mut(action="jump"), "action: expected one of"),
        (_mut(confidence=1.5), "confidence: expected a number in \\[0, 1\\]"),
        (_mut(yaw_deg=270.0), "yaw_deg: expected a number in \\[-180, 180\\]"),
        (_mut(speed_mps=-0.1), "speed_mps: expected a number >= 0"),
        (_mut(position_m=[0, 0]), "position_m: expected \\[x, y, z\\]"),
        (_mut(position_m=[0, "a", 0]), "position_m\\[1\\]"),
        ({"v": 1, "type": "heartbeat", "seq": 0, "ts": 1.0, "state": "asleep"}, "state: expected one of"),
        ({"v": 1, "type": "heartbeat", "seq": 0, "ts": 1.0}, "missing keys \\['state'\\]"),
    ],
)
def test_validator_rejects(data: bytes | dict[str, Any], match: str) -> None:
    with pytest.raises(InputError, match=match):
        validate_datagram(data)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"action": "jump"}, "action must be one of"), ({"position_m": (0.0, 0.0)}, "position_m must have 3")],
)
def test_command_validation(kwargs: dict[str, Any], match: str) -> None:
    base: dict[str, Any] = {"user_id": 1, "action": "still", "confidence": 1.0, "yaw_deg": 0.0,
                            "speed_mps": 0.0, "position_m": (0.0, 0.0, 0.0), "timestamp_s": 0.0}
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        LocomotionCommand(**base)


def test_heartbeat_state_checked() -> None:
    with pytest.raises(ValueError, match="state must be one of"):
        heartbeat_message("asleep", 0, 1.0)
