"""UDP protocol v1 (SPEC.md): the datagrams and their validator.

One UTF-8 JSON object per datagram::

    {"v": 1, "type": "locomotion", "seq", "ts", "user_id", "action", "confidence",
     "yaw_deg", "speed_mps", "position_m": [x, y, z]}
    {"v": 1, "type": "heartbeat", "seq", "ts", "state"}
    {"v": 1, "type": "head", "seq", "ts", "user_id", "position_m": [x, y, z],
     "forward": [x, y, z], "up": [x, y, z], "predicted_ms"}          (additive, issue 20)
    {"v": 1, "type": "navigation", "seq", "ts", "mode", "user_ids"}   (additive, issue 20)

Navigation modes (issue 20): in ``each`` mode one ``locomotion`` stream per navigator, each with
its ``user_id`` (OSC ``/cave/locomotion/{user_id}``); in ``group`` mode one stream with
``user_id`` null (OSC ``/cave/locomotion`` with user_id -1: OSC has no null). A ``navigation``
datagram names the mode and the streams' user ids (the group's members) with every heartbeat
and at once when they change.

``ts`` is Unix time in seconds: for ``locomotion`` and ``head`` the capture time of the camera
frames the command was computed from (so a receiver sees the age of what it gets),
for ``heartbeat`` the time it was sent. A ``head`` pose is for ``ts + predicted_ms``.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

from pipeline.errors import InputError
from pipeline.skeleton import ACTIONS

if TYPE_CHECKING:
    from pipeline.head.tracker import HeadPose

PROTOCOL_VERSION = 1
STATES = ("stopped", "starting", "running", "stalled", "error")  # stalled: running, no frame for 0.5 s
OSC_ADDRESS = "/cave/locomotion"
MAX_DATAGRAM_BYTES = 1400  # stays inside one Ethernet frame

_LOCOMOTION_KEYS = {"v", "type", "seq", "ts", "user_id", "action", "confidence", "yaw_deg",
                    "speed_mps", "position_m"}
_HEARTBEAT_KEYS = {"v", "type", "seq", "ts", "state"}
_HEAD_KEYS = {"v", "type", "seq", "ts", "user_id", "position_m", "forward", "up", "predicted_ms"}
_NAVIGATION_KEYS = {"v", "type", "seq", "ts", "mode", "user_ids"}  # additive (issue 20)
NAVIGATION_MODES = ("single", "each", "group")
MAX_NAVIGATION_IDS = 64
OSC_GROUP_USER_ID = -1  # the group stream's user_id in OSC, which has no null
_PROMPT_KEYS = {"v", "type", "seq", "ts", "text", "label", "remaining_s"}  # additive (issue 18)
_HOLD_KEYS = {"v", "type", "seq", "ts", "held", "by"}  # additive: the hold (the operator's or a session's)
#: who holds navigation: the operator, or a controller (CC) session's own hold while it runs
HOLD_BY: tuple[str, ...] = ("operator", "session")
MAX_PROMPT_CHARS = 200
OSC_HEAD_ADDRESS = "/cave/head"  # + "/{user_id}"
UNIT_TOLERANCE = 0.01  # forward and up are unit vectors to within this


@dataclass(frozen=True, slots=True)
class LocomotionCommand:
    """A navigator's (or the group's) command for one frame.

    user_id: the navigator; None = the group's shared command (group mode, issue 20).
    timestamp_s: capture time of the frames it came from, ``time.monotonic()`` seconds.
    position_m: (x, y, z) floor position in the CAVE frame, metres.
    per_user: one of several streams (each mode): OSC at ``/cave/locomotion/{user_id}``.
    """

    user_id: int | None
    action: str
    confidence: float
    yaw_deg: float
    speed_mps: float
    position_m: tuple[float, float, float]
    timestamp_s: float
    per_user: bool = False

    def __post_init__(self) -> None:
        if self.per_user and self.user_id is None:
            raise ValueError("a per-user stream needs a user_id, got None")
        if self.action not in ACTIONS:
            raise ValueError(f"action must be one of {ACTIONS}, got {self.action!r}")
        if len(self.position_m) != 3:
            raise ValueError(f"position_m must have 3 values, got {len(self.position_m)}")

    def held(self) -> LocomotionCommand:
        """This command while the operator holds navigation: ``still``, speed 0, confidence 1 (the
        operator's decision, not the recogniser's guess); the user, yaw and position as they are."""
        return replace(self, action="still", confidence=1.0, speed_mps=0.0)


def _finite(x: float, nd: int) -> float:
    x = float(x)
    return round(x, nd) if math.isfinite(x) else 0.0


def locomotion_message(cmd: LocomotionCommand, seq: int, ts_unix: float) -> dict[str, Any]:
    return {
        "v": PROTOCOL_VERSION,
        "type": "locomotion",
        "seq": int(seq),
        "ts": round(float(ts_unix), 6),
        "user_id": None if cmd.user_id is None else int(cmd.user_id),
        "action": cmd.action,
        "confidence": _finite(min(max(cmd.confidence, 0.0), 1.0), 4),
        "yaw_deg": _finite(cmd.yaw_deg, 2),
        "speed_mps": _finite(cmd.speed_mps, 3),
        "position_m": [_finite(v, 4) for v in cmd.position_m],
    }


def heartbeat_message(state: str, seq: int, ts_unix: float) -> dict[str, Any]:
    if state not in STATES:
        raise ValueError(f"state must be one of {STATES}, got {state!r}")
    return {"v": PROTOCOL_VERSION, "type": "heartbeat", "seq": int(seq), "ts": round(float(ts_unix), 6),
            "state": state}


#: OSC type tags of ``/cave/locomotion``: user_id, action, confidence, yaw_deg, speed_mps, x, y, z, ts.
#: ``ts`` is a 64-bit double (tag ``d``), Unix seconds: a float32 resolves only to 128 s at
#: today's epoch (issue 15); the other numbers are float32, ample for their ranges.
OSC_LOCOMOTION_TYPES = "isffffffd"


def osc_locomotion_message(cmd: LocomotionCommand, ts_unix: float, address: str | None = None) -> bytes:
    """The OSC message carrying ``cmd`` (types :data:`OSC_LOCOMOTION_TYPES`) at ``address``, by
    default ``/cave/locomotion`` (``/cave/locomotion/{user_id}`` for a per-user stream)."""
    from pythonosc.osc_message_builder import OscMessageBuilder

    if address is None:
        per_user = cmd.per_user and cmd.user_id is not None
        address = f"{OSC_ADDRESS}/{cmd.user_id}" if per_user else OSC_ADDRESS
    user = OSC_GROUP_USER_ID if cmd.user_id is None else int(cmd.user_id)
    values: list[Any] = [user, cmd.action, _finite(min(max(cmd.confidence, 0.0), 1.0), 4),
                         _finite(cmd.yaw_deg, 2), _finite(cmd.speed_mps, 3),
                         *(_finite(v, 4) for v in cmd.position_m), float(ts_unix)]
    builder = OscMessageBuilder(address=address)
    for tag, value in zip(OSC_LOCOMOTION_TYPES, values, strict=True):
        builder.add_arg(value, arg_type=tag)
    return bytes(builder.build().dgram)


def navigation_message(mode: str, user_ids: Any, seq: int, ts_unix: float) -> dict[str, Any]:
    """The navigation mode and its streams' user ids (each: the navigators; group: its members;
    single: the navigator, if any). Additive, issue 20."""
    if mode not in NAVIGATION_MODES:
        raise ValueError(f"mode must be one of {NAVIGATION_MODES}, got {mode!r}")
    return {"v": PROTOCOL_VERSION, "type": "navigation", "seq": int(seq), "ts": round(float(ts_unix), 6),
            "mode": mode, "user_ids": sorted(int(u) for u in user_ids)[:MAX_NAVIGATION_IDS]}


def hold_message(by: str | None, seq: int, ts_unix: float) -> dict[str, Any]:
    """Whether navigation is held (every ``locomotion`` says ``still`` while ``held``) and by whom
    (``by``: "operator", or "session" for a controller session's own hold; None: not held): sent
    when it changes and after every heartbeat while held. Additive."""
    if by is not None and by not in HOLD_BY:
        raise ValueError(f"by must be one of {HOLD_BY} or None, got {by!r}")
    return {"v": PROTOCOL_VERSION, "type": "hold", "seq": int(seq), "ts": round(float(ts_unix), 6),
            "held": by is not None, "by": by}


def _vector(values: Any, nd: int) -> list[float]:
    return [_finite(v, nd) for v in values]


def prompt_message(text: str, label: str, remaining_s: float, seq: int, ts_unix: float) -> dict[str, Any]:
    """The participant's current instruction while a recording protocol runs (additive, issue 18)."""
    if label not in ACTIONS:
        raise ValueError(f"label must be one of {ACTIONS}, got {label!r}")
    return {"v": PROTOCOL_VERSION, "type": "prompt", "seq": int(seq), "ts": round(float(ts_unix), 6),
            "text": str(text)[:MAX_PROMPT_CHARS], "label": label,
            "remaining_s": _finite(max(remaining_s, 0.0), 2)}


def head_message(pose: HeadPose, seq: int, ts_unix: float) -> dict[str, Any]:
    """The ``head`` datagram of a :class:`pipeline.head.tracker.HeadPose` (``ts_unix``: the
    capture time of its frames as Unix seconds)."""
    return {
        "v": PROTOCOL_VERSION,
        "type": "head",
        "seq": int(seq),
        "ts": round(float(ts_unix), 6),
        "user_id": int(pose.user_id),
        "position_m": _vector(pose.position_m, 4),
        "forward": _vector(pose.forward, 5),
        "up": _vector(pose.up, 5),
        "predicted_ms": _finite(max(pose.predicted_ms, 0.0), 2),
    }


#: OSC type tags of ``/cave/head/{user_id}``: user_id, x, y, z, forward x, y, z, up x, y, z,
#: predicted_ms (float32), ts (64-bit double, Unix seconds, as in ``/cave/locomotion``).
OSC_HEAD_TYPES = "i" + "f" * 10 + "d"


def osc_head_message(pose: HeadPose, ts_unix: float) -> bytes:
    """The OSC message ``/cave/head/{user_id}`` carrying ``pose`` (types :data:`OSC_HEAD_TYPES`)."""
    from pythonosc.osc_message_builder import OscMessageBuilder

    values: list[Any] = [int(pose.user_id), *_vector(pose.position_m, 4), *_vector(pose.forward, 5),
                         *_vector(pose.up, 5), _finite(max(pose.predicted_ms, 0.0), 2), float(ts_unix)]
    builder = OscMessageBuilder(address=f"{OSC_HEAD_ADDRESS}/{int(pose.user_id)}")
    for tag, value in zip(OSC_HEAD_TYPES, values, strict=True):
        builder.add_arg(value, arg_type=tag)
    return bytes(builder.build().dgram)


def encode(message: dict[str, Any]) -> bytes:
    data = json.dumps(message, separators=(",", ":"), allow_nan=False).encode("utf-8")
    if len(data) > MAX_DATAGRAM_BYTES:
        raise ValueError(f"datagram of {len(data)} bytes exceeds {MAX_DATAGRAM_BYTES}")
    return data


def _number(msg: dict[str, Any], key: str) -> float:
    value = msg[key]
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise InputError(f"{key}: expected a finite number, got {value!r}")
    return float(value)


def _integer(msg: dict[str, Any], key: str, minimum: int) -> int:
    value = msg[key]
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise InputError(f"{key}: expected an integer >= {minimum}, got {value!r}")
    return value


def validate_datagram(data: bytes | str | dict[str, Any]) -> dict[str, Any]:
    """The datagram as a dict if it follows protocol v1; :class:`InputError` saying why not."""
    if isinstance(data, dict):
        msg = data
    else:
        try:
            text = data.decode("utf-8") if isinstance(data, bytes) else data
            msg = json.loads(text)
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"not UTF-8 JSON: {exc}") from None
    if not isinstance(msg, dict):
        raise InputError(f"expected a JSON object, got {type(msg).__name__}")
    if msg.get("v") != PROTOCOL_VERSION:
        raise InputError(f"v: expected {PROTOCOL_VERSION}, got {msg.get('v')!r}")
    kind = msg.get("type")
    keys = {"locomotion": _LOCOMOTION_KEYS, "heartbeat": _HEARTBEAT_KEYS,
            "head": _HEAD_KEYS, "prompt": _PROMPT_KEYS,
            "navigation": _NAVIGATION_KEYS, "hold": _HOLD_KEYS}.get(kind)  # type: ignore[arg-type]
    if keys is None:
        raise InputError(f"type: expected 'locomotion', 'heartbeat', 'head', 'prompt', 'navigation' or "
                         f"'hold', got {kind!r}")
    if missing := keys - msg.keys():
        raise InputError(f"{kind}: missing keys {sorted(missing)}")
    if extra := msg.keys() - keys:
        raise InputError(f"{kind}: unknown keys {sorted(extra)}")
    _integer(msg, "seq", 0)
    if _number(msg, "ts") <= 0:
        raise InputError(f"ts: expected Unix seconds > 0, got {msg['ts']!r}")
    if kind == "heartbeat":
        if msg["state"] not in STATES:
            raise InputError(f"state: expected one of {STATES}, got {msg['state']!r}")
        return msg
    if kind == "head":
        return _validate_head(msg)
    if kind == "prompt":
        return _validate_prompt(msg)
    if kind == "navigation":
        return _validate_navigation(msg)
    if kind == "hold":
        if not isinstance(msg["held"], bool):
            raise InputError(f"held: expected true or false, got {msg['held']!r}")
        if msg["held"] and msg["by"] not in HOLD_BY:
            raise InputError(f"by: expected one of {HOLD_BY} while held, got {msg['by']!r}")
        if not msg["held"] and msg["by"] is not None:
            raise InputError(f"by: expected null when not held, got {msg['by']!r}")
        return msg
    if msg["user_id"] is not None:  # null: the group's command (issue 20)
        _integer(msg, "user_id", 0)
    if msg["action"] not in ACTIONS:
        raise InputError(f"action: expected one of {ACTIONS}, got {msg['action']!r}")
    if not 0.0 <= _number(msg, "confidence") <= 1.0:
        raise InputError(f"confidence: expected a number in [0, 1], got {msg['confidence']!r}")
    if not -180.0 <= _number(msg, "yaw_deg") <= 180.0:
        raise InputError(f"yaw_deg: expected a number in [-180, 180], got {msg['yaw_deg']!r}")
    if _number(msg, "speed_mps") < 0:
        raise InputError(f"speed_mps: expected a number >= 0, got {msg['speed_mps']!r}")
    _xyz(msg, "position_m")
    return msg


def _xyz(msg: dict[str, Any], key: str) -> list[float]:
    vec = msg[key]
    if not isinstance(vec, list) or len(vec) != 3:
        raise InputError(f"{key}: expected [x, y, z], got {vec!r}")
    return [_number({f"{key}[{i}]": vec[i]}, f"{key}[{i}]") for i in range(3)]


def _validate_head(msg: dict[str, Any]) -> dict[str, Any]:
    """The checks of a ``head`` datagram after the common ones."""
    _integer(msg, "user_id", 0)
    _xyz(msg, "position_m")
    unit = {}
    for key in ("forward", "up"):
        vec = _xyz(msg, key)
        norm = math.sqrt(sum(v * v for v in vec))
        if abs(norm - 1.0) > UNIT_TOLERANCE:
            raise InputError(f"{key}: expected a unit vector, got length {norm:.4f}")
        unit[key] = vec
    dot = sum(a * b for a, b in zip(unit["forward"], unit["up"], strict=True))
    if abs(dot) > UNIT_TOLERANCE:
        raise InputError(f"forward and up: expected perpendicular vectors, got cos {dot:.4f}")
    if _number(msg, "predicted_ms") < 0:
        raise InputError(f"predicted_ms: expected a number >= 0, got {msg['predicted_ms']!r}")
    return msg


def _validate_prompt(msg: dict[str, Any]) -> dict[str, Any]:
    """The checks of a ``prompt`` datagram after the common ones."""
    text = msg["text"]
    if not isinstance(text, str) or not 0 < len(text) <= MAX_PROMPT_CHARS:
        raise InputError(f"text: expected a string of 1-{MAX_PROMPT_CHARS} characters, got {text!r}")
    if msg["label"] not in ACTIONS:
        raise InputError(f"label: expected one of {ACTIONS}, got {msg['label']!r}")
    if _number(msg, "remaining_s") < 0:
        raise InputError(f"remaining_s: expected a number >= 0, got {msg['remaining_s']!r}")
    return msg


def _validate_navigation(msg: dict[str, Any]) -> dict[str, Any]:
    """The checks of a ``navigation`` datagram after the common ones."""
    if msg["mode"] not in NAVIGATION_MODES:
        raise InputError(f"mode: expected one of {NAVIGATION_MODES}, got {msg['mode']!r}")
    ids = msg["user_ids"]
    if not isinstance(ids, list) or len(ids) > MAX_NAVIGATION_IDS:
        raise InputError(f"user_ids: expected a list of at most {MAX_NAVIGATION_IDS} user ids, got {ids!r}")
    for i in range(len(ids)):
        _integer({f"user_ids[{i}]": ids[i]}, f"user_ids[{i}]", 0)
    if len(set(ids)) != len(ids):
        raise InputError(f"user_ids: expected distinct user ids, got {ids!r}")
    if msg["mode"] == "single" and len(ids) > 1:
        raise InputError(f"user_ids: single mode has at most one navigator, got {ids!r}")
    return msg
