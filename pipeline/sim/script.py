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

from pipeline.errors import InputError, read_user_text
from pipeline.sim import ranges

# Actions a segment can ask for. ``turn`` = turning on the spot; it is labelled ``still``.
SEGMENT_ACTIONS: tuple[str, ...] = ("still", "forward", "left", "right", "turn")
# Gestures a still segment can show (the names a script may list).
GESTURES: tuple[str, ...] = ("point", "wave", "cross_arms", "hands_on_hips", "touch_face", "look_around")
# What a segment's person does (its frames' tag), per action; the first is the default
# (forward: ``walk`` / ``run`` by default when the segment travels at walking / running speed).
FORWARD_BEHAVIOURS: tuple[str, ...] = ("march", "walk", "run")
SIDE_BEHAVIOURS: tuple[str, ...] = ("side-step-out-back", "step-together", "shuffle")
STILL_BEHAVIOURS: tuple[str, ...] = (
    "idle",
    "look-around",
    "point",
    "wave",
    "crouch",
    "squat",
    "kneel",
    "kneel-forward",
    "step-back",
    "lunge",
    "bend",
    "lean",
    "tiptoe",
    "jump",
    "sway",
    "dance-on-spot",
    "weight-shift",
    "stretch",
)
TURNING_STILL = ("idle", "look-around", "point", "wave")  # still behaviours a turn may go with
BEHAVIOURS: dict[str, tuple[str, ...]] = {
    "forward": FORWARD_BEHAVIOURS,
    "left": SIDE_BEHAVIOURS,
    "right": SIDE_BEHAVIOURS,
    "still": STILL_BEHAVIOURS,
    "turn": ("turn",),
}
WALK_MIN_MPS = 0.3  # a forward segment travelling at least this fast walks by default ...
RUN_MIN_MPS = 1.9  # ... and runs from this speed on

CADENCE_RANGE = (0.5, 3.5)  # steps/s accepted in a script (0.5-2.6 in place, up to 3.2 running)
KNEE_LIFT_RANGE = (0.0, 0.4)  # m, peak rise of the ankle
STEP_WIDTH_RANGE = (0.0, 0.6)  # m, lateral step-out distance of side steps
BLEND_RANGE = (0.0, 1.0)  # s
TRAVEL_RANGE = (0.0, 4.0)  # m/s, forward only
PAUSE_RANGE = (0.2, 1.0)  # s, both feet down between two steps of one bout (TEAM.md LABELS)
ARM_SWING_RANGE = (0.0, 60.0)  # deg
SLIDE_RANGE = (-0.15, 0.15)  # m, stance slide of a marching foot (+ back, - forward)
UNIT_RANGE = (0.0, 1.0)  # pause_prob, irregularity, intensity
ASYMMETRY_RANGE = (0.5, 2.0)  # left lift / right lift


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
    blend_s: transition time of the upper body into this segment's motion (0.1-0.4 s
        realistic); None = the user's own.
    travel_mps: forward only: real displacement speed along the facing direction (bystanders
        walking around the CAVE); 0 = marching in place (plus the person's own slight creep).
    behaviour: what the person does, from ``BEHAVIOURS[action]`` (the frames' tag);
        None = the action's default (forward: march, or walk / run when travelling).
    pause_prob: stepping: chance that a step is followed by a pause; None = the user's own.
    pause_s: stepping: [min, max] length of those pauses (both feet down), within 0.2-1.0 s.
    arm_swing_deg: stepping: peak arm swing (0 = arms still); None = the user's own.
    slide_m: marching: the stance foot slides back this far (negative: forward); None = own.
    irregularity: stepping: random spread of step timing, lift and placement (0-1, 0.1 is
        noticeable); None = the user's own.
    asymmetry: stepping: left lift / right lift (0.5-2; the higher-lifting foot also swings a
        little longer); None = the user's own.
    intensity: still behaviours: how far it goes (0-1: crouch depth, lean angle, jump height);
        None = drawn at random.
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
    behaviour: str | None = None
    pause_prob: float | None = None
    pause_s: tuple[float, float] | None = None
    arm_swing_deg: float | None = None
    slide_m: float | None = None
    irregularity: float | None = None
    asymmetry: float | None = None
    intensity: float | None = None

    def __post_init__(self) -> None:
        if self.action not in SEGMENT_ACTIONS:
            raise InputError(f"action must be one of {', '.join(SEGMENT_ACTIONS)}, got {self.action!r}")
        if self.behaviour is not None and self.behaviour not in BEHAVIOURS[self.action]:
            raise InputError(
                f"behaviour {self.behaviour!r} is not one of {self.action!r}: "
                f"{', '.join(BEHAVIOURS[self.action])}"
            )
        d = _finite("duration_s", self.duration_s)
        if d <= 0:
            raise InputError(f"duration_s must be > 0, got {self.duration_s}")
        object.__setattr__(self, "duration_s", d)
        for name, rng in (
            ("cadence_steps_per_s", CADENCE_RANGE),
            ("knee_lift_m", KNEE_LIFT_RANGE),
            ("step_width_m", STEP_WIDTH_RANGE),
            ("blend_s", BLEND_RANGE),
            ("pause_prob", UNIT_RANGE),
            ("arm_swing_deg", ARM_SWING_RANGE),
            ("slide_m", SLIDE_RANGE),
            ("irregularity", UNIT_RANGE),
            ("intensity", UNIT_RANGE),
            ("asymmetry", ASYMMETRY_RANGE),
        ):
            raw = getattr(self, name)
            if raw is not None:
                v = _finite(name, raw)
                _in_range(name, v, *rng)
                object.__setattr__(self, name, v)
        if self.turn_deg is not None:
            object.__setattr__(self, "turn_deg", _finite("turn_deg", self.turn_deg))
            if self.action == "still" and self.turn_deg != 0 and self.behaviour_name not in TURNING_STILL:
                raise InputError(
                    f"a {self.behaviour} segment cannot turn (turn_deg); turn in a segment of its own"
                )
        travel = _finite("travel_mps", self.travel_mps)
        _in_range("travel_mps", travel, *TRAVEL_RANGE)
        if travel > 0 and self.action != "forward":
            raise InputError(f"travel_mps is only for forward segments, not {self.action!r}")
        object.__setattr__(self, "travel_mps", travel)
        if self.behaviour in ("walk", "run") and travel <= 0:
            raise InputError(f"a {self.behaviour} segment needs travel_mps > 0")
        if self.pause_s is not None:
            ps = self.pause_s
            if isinstance(ps, str) or not isinstance(ps, list | tuple) or len(ps) != 2:
                raise InputError(f"pause_s must be [min, max] seconds, got {ps!r}")
            lo, hi = _finite("pause_s[0]", ps[0]), _finite("pause_s[1]", ps[1])
            if not PAUSE_RANGE[0] <= lo <= hi <= PAUSE_RANGE[1]:
                raise InputError(
                    f"pause_s must satisfy {PAUSE_RANGE[0]} <= min <= max <= {PAUSE_RANGE[1]}, got {ps}"
                )
            object.__setattr__(self, "pause_s", (lo, hi))
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
    def behaviour_name(self) -> str:
        """The behaviour this segment shows (its tag), with the action's default filled in."""
        if self.behaviour is not None:
            return self.behaviour
        if self.action == "forward":
            if self.travel_mps >= RUN_MIN_MPS:
                return "run"
            return "walk" if self.travel_mps >= WALK_MIN_MPS else "march"
        return BEHAVIOURS[self.action][0]

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
        if "pause_s" in d:
            d["pause_s"] = list(d["pause_s"])
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
    text = read_user_text(p, "motion script")
    as_toml = p.suffix.lower() == ".toml"
    try:
        data = tomllib.loads(text) if as_toml else json.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        kind = "TOML" if as_toml else "JSON"
        raise InputError(f"{p}: not valid {kind} ({exc})") from exc
    return script_from_dict(data, str(p))


def save_script(path: str | Path, script: MotionScript) -> None:
    Path(path).write_text(json.dumps(script.to_dict(), indent=2) + "\n", encoding="utf-8")


DEFAULT_ACTION_WEIGHTS: dict[str, float] = ranges.ACTION_WEIGHTS["mixed"]
TRAVEL_RADIUS_M = 0.8  # walks, runs and step-together stay within this of the routine's start


class _Floor:
    """Where a routine being drawn has taken the person: floor position and facing."""

    def __init__(self, start_xy: tuple[float, float], yaw_deg: float, radius_m: float) -> None:
        self.start = np.asarray(start_xy, dtype=np.float64)
        self.xy = self.start.copy()
        self.yaw = yaw_deg
        self.radius = radius_m

    def direction(self, deg_from_facing: float = 0.0) -> np.ndarray:
        a = math.radians(self.yaw + deg_from_facing)
        return np.array([-math.sin(a), math.cos(a)])

    def room(self, deg_from_facing: float = 0.0, extra: float = 0.0) -> float:
        """How far the person can go that way before leaving the circle (radius + ``extra``)."""
        u = self.direction(deg_from_facing)
        d = self.xy - self.start
        b = float(d @ u)
        c = float(d @ d) - (self.radius + extra) ** 2
        return max(0.0, -b + math.sqrt(max(b * b - c, 0.0)))

    def towards_start_deg(self) -> float:
        d = self.start - self.xy
        want = math.degrees(math.atan2(-d[0], d[1]))
        return float((want - self.yaw + 180.0) % 360.0 - 180.0)


def random_script(
    rng: np.random.Generator,
    duration_s: float,
    *,
    kind: str = "mixed",
    action_weights: dict[str, float] | None = None,
    segment_s: tuple[float, float] | None = None,
    start_xy_m: tuple[float, float] = (0.0, 0.0),
    start_yaw_deg: float | None = None,
    repeat_prob: float = 0.0,
    travel_radius_m: float = TRAVEL_RADIUS_M,
) -> MotionScript:
    """A random routine of ``duration_s`` seconds: random behaviours switching at any moment.

    kind: one of ``ranges.ROUTINE_KINDS`` (``mixed``, ``stepping``, ``still``, ``still-heavy``;
    see :mod:`pipeline.sim.ranges` for what each draws and every parameter range).
    action_weights: override the kind's action weights. segment_s: override the kind's segment
    lengths (still behaviours keep their own). Consecutive segments differ in action unless
    ``repeat_prob`` allows a repeat (a change of cadence or style mid-bout). Walks, runs and
    step-together travel for real but stay within ``travel_radius_m`` of the start (the routine
    turns back towards it when it runs out of room). ``start_yaw_deg`` None = uniform in
    [-180, 180).
    """
    d = _finite("duration_s", duration_s)
    if d <= 0:
        raise InputError(f"duration_s must be > 0, got {duration_s}")
    if kind not in ranges.ROUTINE_KINDS:
        raise InputError(f"kind must be one of {', '.join(ranges.ROUTINE_KINDS)}, got {kind!r}")
    lo, hi = segment_s if segment_s is not None else ranges.SEGMENT_S[kind]
    if not 0 < lo <= hi:
        raise InputError(f"segment_s must be 0 < min <= max, got {segment_s}")
    weights = dict(action_weights or ranges.ACTION_WEIGHTS[kind])
    bad = [a for a in weights if a not in SEGMENT_ACTIONS]
    if bad or not weights or min(weights.values()) < 0 or sum(weights.values()) <= 0:
        raise InputError(
            f"action_weights must map actions of {SEGMENT_ACTIONS} to weights >= 0, got {weights}"
        )
    actions = list(weights)
    yaw = float(rng.uniform(-180.0, 180.0)) if start_yaw_deg is None else float(start_yaw_deg)
    floor = _Floor(start_xy_m, yaw, travel_radius_m)
    segments: list[Segment] = []
    prev: str | None = None
    while sum(s.duration_s for s in segments) < d - 1e-3:
        for _ in range(20):
            action = ranges.pick(rng, weights)
            if action != prev or len(actions) == 1 or rng.random() < repeat_prob:
                break
        may_turn = "turn" in weights and not (segments and segments[-1].action == "turn")
        for seg in _draw(rng, kind, action, (lo, hi), floor, may_turn):
            left = d - sum(s.duration_s for s in segments)
            if left < 1e-3:
                break
            if seg.duration_s > left:
                seg = _shortened(seg, left)
            segments.append(seg)
        prev = action
    return MotionScript(tuple(segments), start_xy_m=start_xy_m, start_yaw_deg=yaw)


def _shortened(seg: Segment, duration_s: float) -> Segment:
    """``seg`` cut to ``duration_s`` (its turn scaled with it)."""
    kw = {f.name: getattr(seg, f.name) for f in fields(Segment)}
    if seg.turn_deg is not None:
        kw["turn_deg"] = seg.turn_deg * duration_s / seg.duration_s
    elif seg.action == "turn":
        kw["turn_deg"] = seg.yaw_change_deg * duration_s / seg.duration_s
    kw["duration_s"] = duration_s
    if seg.behaviour in ("walk", "run") and duration_s < ranges.MIN_RUN_S:
        kw["behaviour"], kw["travel_mps"] = "march", 0.0  # no time to get going
    if seg.action == "still" and seg.behaviour is not None and duration_s < ranges.MIN_BEHAVIOUR_S:
        kw["behaviour"], kw["intensity"] = None, None  # too short to show it: just standing
    return Segment(**kw)


def _draw(
    rng: np.random.Generator,
    kind: str,
    action: str,
    seg_s: tuple[float, float],
    floor: _Floor,
    may_turn: bool,
) -> list[Segment]:
    """One drawn part of a routine: usually one segment, a turn back first when a walk has no room
    (if it may turn: not right after a turn, not when the routine has no turns; else it marches)."""
    if action == "still":
        behaviour = ranges.pick(rng, ranges.STILL_WEIGHTS[kind])
        dur = float(rng.uniform(*ranges.BEHAVIOUR_S.get(behaviour, seg_s)))
        return [Segment("still", dur, **ranges.still_kwargs(rng, behaviour))]  # no turn: yaw kept
    if action == "turn":
        dur = float(rng.uniform(*seg_s))
        turned = Segment(
            "turn", dur, turn_deg=ranges.turn_deg(rng, dur), blend_s=float(rng.uniform(0.1, 0.4))
        )
        floor.yaw += turned.yaw_change_deg
        return [turned]
    bout_s = ranges.STILL_HEAVY_BOUT_S if kind == "still-heavy" else seg_s
    dur = float(rng.uniform(*bout_s))
    if action == "forward":
        behaviour = ranges.pick(rng, ranges.FORWARD_WEIGHTS)
    else:
        behaviour = ranges.pick(rng, ranges.SIDE_WEIGHTS)
    kw = ranges.stepping_kwargs(rng, action, behaviour)
    out: list[Segment] = []
    if behaviour in ("walk", "run"):
        run = behaviour == "run"
        extra = ranges.RUN_EXTRA_M if run else 0.0  # a jog may go a little further out
        if floor.room(extra=extra) < (1.2 if run else 0.6) and may_turn:  # turn back towards the start
            turn = floor.towards_start_deg() + float(rng.uniform(-20.0, 20.0))
            t_dur = max(0.5, abs(turn) / float(rng.uniform(90.0, ranges.TURN_RATE_DPS)))
            out.append(Segment("turn", t_dur, turn_deg=turn))
            floor.yaw += turn
        dist = min(float(rng.uniform(*ranges.WALK_M)), floor.room(extra=extra))
        if run:  # short of room a run is a slower jog
            kw["travel_mps"] = min(kw["travel_mps"], dist / ranges.MIN_RUN_S)
        dur = ranges.travel_duration_s(dist, kw["travel_mps"], run)
        too_slow = run and kw["travel_mps"] < ranges.JOG_MIN_MPS
        if dist < 0.4 or too_slow or dur < (ranges.MIN_RUN_S if run else ranges.MIN_TRAVEL_S):  # march
            kw = ranges.stepping_kwargs(rng, action, "march")
            dur = float(rng.uniform(*bout_s))
        else:
            floor.xy = floor.xy + dist * floor.direction()
    elif behaviour in ("step-together", "shuffle"):
        side = 90.0 if action == "left" else -90.0  # counter-clockwise from the facing: the left
        reach = kw["step_width_m"] * max(1.0, kw["cadence_steps_per_s"] * dur / 2.0)
        if reach > floor.room(side):
            kw = ranges.stepping_kwargs(rng, action, "side-step-out-back")
        else:
            floor.xy = floor.xy + reach * floor.direction(side)
    elif behaviour == "march" and "travel_mps" in kw:
        kw["travel_mps"] = min(kw["travel_mps"], 0.3 / dur)
        floor.xy = floor.xy + kw["travel_mps"] * dur * floor.direction()
    out.append(Segment(action, dur, **kw))
    floor.yaw += out[-1].yaw_change_deg  # marching may steer
    return out
