"""Motion scripts: the routine an animated user performs ("still 3 s, forward 5 s, left 2 s ...").

A script is a tuple of :class:`Segment` plus a start position and facing direction.
Scripts come from JSON or TOML files (:func:`load_script`) or are drawn at random
(:func:`random_script`, used to generate training data).

File format (JSON; TOML the same keys, segments as ``[[segments]]`` tables)::

    {"start_xy_m": [0, 0], "start_yaw_deg": 0,
     "segments": [{"action": "still", "duration_s": 3},
                  {"action": "forward", "duration_s": 5, "cadence_steps_per_s": 1.8},
                  {"action": "turn", "duration_s": 2, "turn_deg": 90},
                  {"action": "left", "duration_s": 2}]}
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.errors import InputError

# Actions a segment can ask for. ``turn`` = turning on the spot; it is labelled ``still``.
SEGMENT_ACTIONS: tuple[str, ...] = ("still", "forward", "left", "right", "turn")
# Gestures a still segment can show (the names a script may list).
GESTURES: tuple[str, ...] = ("point", "wave", "cross_arms", "hands_on_hips", "touch_face", "look_around")

CADENCE_RANGE = (0.5, 3.5)  # steps/s accepted in a script (1.2-2.4 is the realistic range)
KNEE_LIFT_RANGE = (0.0, 0.4)  # m, peak rise of the ankle
STEP_WIDTH_RANGE = (0.0, 0.6)  # m, lateral step-out distance of side steps
BLEND_RANGE = (0.0, 1.0)  # s


def _finite(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise InputError(f"{name} must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise InputError(f"{name} must be finite, got {value!r}")
    return v


def _in_range(name: str, value: float | None, lo: float, hi: float) -> None:
    if value is not None and not lo <= value <= hi:
        raise InputError(f"{name} must be in [{lo}, {hi}], got {value}")


@dataclass(frozen=True, slots=True)
class Segment:
    """One part of a routine.

    action: ``still | forward | left | right | turn``.
    duration_s: seconds (> 0).
    cadence_steps_per_s: steps per second of forward/side stepping (and turning steps);
        None = the user's own cadence (drawn per user, 1.2-2.4).
    knee_lift_m: peak rise of the lifted ankle over the floor, metres (forward marching: 0.05-0.25);
        None = the user's own.
    step_width_m: how far a side step goes out, metres; None = the user's own.
    turn_deg: yaw change over the segment, counter-clockwise positive (any action may turn;
        ``turn`` without a value turns 90 degrees).
    gestures: still segments: gestures to show in order (names from ``GESTURES``);
        None = random gestures at the user's own rate; () = none.
    blend_s: transition time into this segment's motion and out of it (0.1-0.4 s realistic);
        None = the user's own.
    travel_mps: forward only: real displacement speed along the facing direction (bystanders
        walking around the CAVE); 0 = marching in place.
    """

    action: str
    duration_s: float
    cadence_steps_per_s: float | None = None
    knee_lift_m: float | None = None
    step_width_m: float | None = None
    turn_deg: float | None = None
    gestures: tuple[str, ...] | None = None
    blend_s: float | None = None
    travel_mps: float = 0.0

    def __post_init__(self) -> None:
        if self.action not in SEGMENT_ACTIONS:
            raise InputError(f"action must be one of {', '.join(SEGMENT_ACTIONS)}, got {self.action!r}")
        d = _finite("duration_s", self.duration_s)
        if d <= 0:
            raise InputError(f"duration_s must be > 0, got {self.duration_s}")
        object.__setattr__(self, "duration_s", d)
        for name, rng in (
            ("cadence_steps_per_s", CADENCE_RANGE),
            ("knee_lift_m", KNEE_LIFT_RANGE),
            ("step_width_m", STEP_WIDTH_RANGE),
            ("blend_s", BLEND_RANGE),
        ):
            raw = getattr(self, name)
            if raw is not None:
                v = _finite(name, raw)
                _in_range(name, v, *rng)
                object.__setattr__(self, name, v)
        if self.turn_deg is not None:
            object.__setattr__(self, "turn_deg", _finite("turn_deg", self.turn_deg))
        travel = _finite("travel_mps", self.travel_mps)
        if not 0.0 <= travel <= 2.0:
            raise InputError(f"travel_mps must be in [0, 2], got {travel}")
        if travel > 0 and self.action != "forward":
            raise InputError(f"travel_mps is only for forward segments, not {self.action!r}")
        object.__setattr__(self, "travel_mps", travel)
        if self.gestures is not None:
            if isinstance(self.gestures, str) or not isinstance(self.gestures, list | tuple):
                raise InputError(f"gestures must be a list of names, got {self.gestures!r}")
            bad = [g for g in self.gestures if g not in GESTURES]
            if bad:
                raise InputError(f"unknown gesture(s) {bad}; gestures are {', '.join(GESTURES)}")
            if self.action != "still" and self.gestures:
                raise InputError(f"gestures are only for still segments, not {self.action!r}")
            object.__setattr__(self, "gestures", tuple(self.gestures))

    @property
    def label(self) -> str:
        """The ground-truth action label of this segment's frames (``turn`` -> ``still``)."""
        return "still" if self.action == "turn" else self.action

    @property
    def yaw_change_deg(self) -> float:
        if self.turn_deg is not None:
            return float(self.turn_deg)
        return 90.0 if self.action == "turn" else 0.0

    def to_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in asdict(self).items() if v is not None}
        if d.get("travel_mps") == 0.0:
            del d["travel_mps"]
        if "gestures" in d:
            d["gestures"] = list(d["gestures"])
        return d


@dataclass(frozen=True, slots=True)
class MotionScript:
    """A routine: segments played one after the other from a start pose.

    segments: at least one :class:`Segment`.
    start_xy_m: floor position (x, y) in the CAVE frame, metres.
    start_yaw_deg: initial facing direction, 0 = +Y, counter-clockwise positive.
    """

    segments: tuple[Segment, ...]
    start_xy_m: tuple[float, float] = (0.0, 0.0)
    start_yaw_deg: float = 0.0

    def __post_init__(self) -> None:
        segs = tuple(self.segments)
        if not segs:
            raise InputError("a motion script needs at least one segment")
        if not all(isinstance(s, Segment) for s in segs):
            raise InputError("segments must be Segment objects")
        object.__setattr__(self, "segments", segs)
        xy = self.start_xy_m
        if not isinstance(xy, list | tuple) or len(xy) != 2:
            raise InputError(f"start_xy_m must be [x, y], got {xy!r}")
        xy_f = (_finite("start_xy_m[0]", xy[0]), _finite("start_xy_m[1]", xy[1]))
        object.__setattr__(self, "start_xy_m", xy_f)
        object.__setattr__(self, "start_yaw_deg", _finite("start_yaw_deg", self.start_yaw_deg))

    @property
    def duration_s(self) -> float:
        return float(sum(s.duration_s for s in self.segments))

    def to_dict(self) -> dict[str, Any]:
        return {
            "start_xy_m": list(self.start_xy_m),
            "start_yaw_deg": self.start_yaw_deg,
            "segments": [s.to_dict() for s in self.segments],
        }


_SEGMENT_KEYS = frozenset(f.name for f in fields(Segment))
_SCRIPT_KEYS = frozenset({"segments", "start_xy_m", "start_yaw_deg"})


def script_from_dict(data: object, source: str = "script") -> MotionScript:
    """Build a script from parsed JSON/TOML; raises InputError naming the bad entry."""
    if not isinstance(data, dict):
        raise InputError(f"{source}: expected an object with a 'segments' list")
    unknown = sorted(set(data) - _SCRIPT_KEYS)
    if unknown:
        raise InputError(f"{source}: unknown key(s) {unknown}; allowed: {sorted(_SCRIPT_KEYS)}")
    raw = data.get("segments")
    if not isinstance(raw, list) or not raw:
        raise InputError(f"{source}: 'segments' must be a non-empty list")
    segments = []
    for i, item in enumerate(raw):
        where = f"{source}: segment {i + 1}"
        if not isinstance(item, dict):
            raise InputError(f'{where}: expected an object like {{"action": "still", "duration_s": 3}}')
        bad = sorted(set(item) - _SEGMENT_KEYS)
        if bad:
            raise InputError(f"{where}: unknown key(s) {bad}; allowed: {sorted(_SEGMENT_KEYS)}")
        for key in ("action", "duration_s"):
            if key not in item:
                raise InputError(f"{where}: missing {key!r}")
        try:
            segments.append(Segment(**item))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from exc
    kwargs: dict[str, Any] = {}
    if "start_xy_m" in data:
        kwargs["start_xy_m"] = data["start_xy_m"]
    if "start_yaw_deg" in data:
        kwargs["start_yaw_deg"] = data["start_yaw_deg"]
    try:
        return MotionScript(tuple(segments), **kwargs)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from exc


def load_script(path: str | Path) -> MotionScript:
    """Read a motion script from a ``.json`` or ``.toml`` file; raises InputError with the reason."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"motion script not found: {p}")
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(f"{p}: cannot read the motion script ({exc})") from exc
    as_toml = p.suffix.lower() == ".toml"
    try:
        data = tomllib.loads(text) if as_toml else json.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        kind = "TOML" if as_toml else "JSON"
        raise InputError(f"{p}: not valid {kind} ({exc})") from exc
    return script_from_dict(data, str(p))


def save_script(path: str | Path, script: MotionScript) -> None:
    Path(path).write_text(json.dumps(script.to_dict(), indent=2) + "\n", encoding="utf-8")


DEFAULT_ACTION_WEIGHTS: dict[str, float] = {
    "still": 0.3,
    "forward": 0.3,
    "left": 0.15,
    "right": 0.15,
    "turn": 0.1,
}


def random_script(
    rng: np.random.Generator,
    duration_s: float,
    *,
    action_weights: dict[str, float] | None = None,
    segment_s: tuple[float, float] = (0.4, 5.0),
    start_xy_m: tuple[float, float] = (0.0, 0.0),
    start_yaw_deg: float | None = None,
    repeat_prob: float = 0.0,
) -> MotionScript:
    """A random routine of ``duration_s`` seconds: random actions switching at any moment.

    Segment lengths are uniform in ``segment_s``; consecutive segments differ in action
    unless ``repeat_prob`` allows a repeat (useful to change cadence mid-walk). Cadence,
    knee lift and turning are drawn per segment; gestures follow the user's own rate.
    ``start_yaw_deg`` None = uniform in [-180, 180).
    """
    d = _finite("duration_s", duration_s)
    if d <= 0:
        raise InputError(f"duration_s must be > 0, got {duration_s}")
    lo, hi = segment_s
    if not 0 < lo <= hi:
        raise InputError(f"segment_s must be 0 < min <= max, got {segment_s}")
    weights = dict(action_weights or DEFAULT_ACTION_WEIGHTS)
    bad = [a for a in weights if a not in SEGMENT_ACTIONS]
    if bad or not weights or min(weights.values()) < 0 or sum(weights.values()) <= 0:
        raise InputError(
            f"action_weights must map actions of {SEGMENT_ACTIONS} to weights >= 0, got {weights}"
        )
    actions = list(weights)
    probs = np.array([weights[a] for a in actions], dtype=np.float64)
    probs /= probs.sum()
    segments: list[Segment] = []
    total = 0.0
    prev: str | None = None
    while total < d - 1e-9:
        for _ in range(20):
            action = str(rng.choice(actions, p=probs))
            if action != prev or len(actions) == 1 or rng.random() < repeat_prob:
                break
        dur = min(float(rng.uniform(lo, hi)), d - total)
        if dur < 1e-3:
            break
        seg_kwargs: dict[str, Any] = {}
        if action in ("forward", "left", "right", "turn"):
            seg_kwargs["cadence_steps_per_s"] = float(rng.uniform(1.2, 2.4))
        if action == "forward":
            seg_kwargs["knee_lift_m"] = float(rng.uniform(0.05, 0.25))
        if action in ("left", "right"):
            seg_kwargs["knee_lift_m"] = float(rng.uniform(0.04, 0.18))
            seg_kwargs["step_width_m"] = float(rng.uniform(0.12, 0.35))
        if action == "turn":  # people turn on the spot at up to ~150 deg/s
            max_turn = float(np.clip(150.0 * dur, 20.0, 180.0))
            seg_kwargs["turn_deg"] = float(rng.choice([-1.0, 1.0]) * rng.uniform(20.0, max_turn))
        elif action == "forward" and rng.random() < 0.2:
            seg_kwargs["turn_deg"] = float(rng.uniform(-45.0, 45.0))  # steering while marching
        seg_kwargs["blend_s"] = float(rng.uniform(0.1, 0.4))
        segments.append(Segment(action, dur, **seg_kwargs))
        total += dur
        prev = action
    yaw = float(rng.uniform(-180.0, 180.0)) if start_yaw_deg is None else float(start_yaw_deg)
    return MotionScript(tuple(segments), start_xy_m=start_xy_m, start_yaw_deg=yaw)
