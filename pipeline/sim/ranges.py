"""What the random routines draw from: routine kinds, behaviour weights and parameter ranges.

One table per routine kind and behaviour; :func:`pipeline.sim.script.random_script` composes
routines from them. The draws return keyword arguments for :class:`pipeline.sim.script.Segment`
(this module knows nothing of the script format, so the format can use it).

Routine kinds:

- ``mixed``: everything: still behaviours of the library, marching, walking, running, side
  steps of every style, turns on the spot; transitions at any moment.
- ``stepping``: mostly stepping bouts of every style, short still moments in between.
- ``still``: only the still library and turns on the spot: every frame is labelled ``still``.
- ``still-heavy``: the still library with short stepping bouts mixed in.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

ROUTINE_KINDS: tuple[str, ...] = ("mixed", "stepping", "still", "still-heavy")

# Action weights per routine kind (``turn`` = turning on the spot, labelled still).
ACTION_WEIGHTS: dict[str, dict[str, float]] = {
    "mixed": {"still": 0.3, "forward": 0.3, "left": 0.15, "right": 0.15, "turn": 0.1},
    "stepping": {"still": 0.12, "forward": 0.44, "left": 0.19, "right": 0.19, "turn": 0.06},
    "still": {"still": 0.85, "turn": 0.15},
    "still-heavy": {"still": 0.58, "forward": 0.14, "left": 0.08, "right": 0.08, "turn": 0.12},
}
FORWARD_WEIGHTS: dict[str, float] = {"march": 0.75, "walk": 0.17, "run": 0.08}
SIDE_WEIGHTS: dict[str, float] = {"side-step-out-back": 0.5, "step-together": 0.3, "shuffle": 0.2}
# Still behaviours per routine kind (the stepping kind keeps its still moments plain).
_LIBRARY = {
    "crouch": 0.08,
    "squat": 0.06,
    "kneel": 0.06,
    "bend": 0.08,
    "lean": 0.08,
    "tiptoe": 0.06,
    "jump": 0.07,
    "sway": 0.06,
    "dance-on-spot": 0.07,
    "weight-shift": 0.08,
    "stretch": 0.06,
    "look-around": 0.08,
    "point": 0.08,
    "wave": 0.06,
}
STILL_WEIGHTS: dict[str, dict[str, float]] = {
    "mixed": {"idle": 0.35, **{k: 0.65 * v / sum(_LIBRARY.values()) for k, v in _LIBRARY.items()}},
    "stepping": {"idle": 1.0},
    "still": {"idle": 0.12, **{k: 0.88 * v / sum(_LIBRARY.values()) for k, v in _LIBRARY.items()}},
    "still-heavy": {"idle": 0.15, **{k: 0.85 * v / sum(_LIBRARY.values()) for k, v in _LIBRARY.items()}},
}
# Segment lengths, seconds: per kind for stepping bouts and plain still, per still behaviour.
SEGMENT_S: dict[str, tuple[float, float]] = {
    "mixed": (0.4, 5.0),
    "stepping": (0.6, 6.0),
    "still": (1.0, 6.0),
    "still-heavy": (1.0, 6.0),
}
MIN_BEHAVIOUR_S = 1.2  # a still behaviour cut shorter than this by the routine's end is plain standing
STILL_HEAVY_BOUT_S = (0.5, 2.5)  # the short stepping bouts of still-heavy routines
BEHAVIOUR_S: dict[str, tuple[float, float]] = {
    "look-around": (2.0, 6.0),
    "point": (1.5, 5.0),
    "wave": (1.5, 5.0),
    "crouch": (2.0, 6.0),
    "squat": (2.0, 6.0),
    "kneel": (3.0, 8.0),
    "bend": (1.5, 4.0),
    "lean": (1.5, 5.0),
    "tiptoe": (1.0, 4.0),
    "jump": (0.8, 3.0),
    "sway": (2.0, 8.0),
    "dance-on-spot": (3.0, 10.0),
    "weight-shift": (3.0, 10.0),
    "stretch": (2.0, 6.0),
}

# Stepping parameter ranges (what issue 14 asks the simulator to cover).
CADENCE_SPS = (0.5, 2.6)  # in place; 70 % of bouts in the common 1.2-2.4
KNEE_LIFT_M = (0.03, 0.30)  # marching; 70 % in the common 0.05-0.22
SIDE_LIFT_M = (0.01, 0.20)
STEP_WIDTH_M = (0.08, 0.45)
PAUSE_BOUT_PROB = 0.35  # bouts with pauses between steps ...
PAUSE_PROB = (0.15, 0.6)  # ... after this share of their steps ...
PAUSE_MAX_S = (0.4, 1.0)  # ... each 0.2 s to this long (both feet down)
ARM_SWING_DEG = (5.0, 45.0)  # 20 % of marching bouts without arm swing
SLIDE_M = (-0.05, 0.08)  # 25 % of marching bouts: the stance foot slides back (or forward)
MARCH_TRAVEL_MPS = (0.02, 0.12)  # 25 % of marching bouts creep forward for real
IRREGULARITY = (0.1, 0.3)  # 30 % of bouts irregular, the rest 0-0.06
ASYMMETRY = (0.7, 1.4)  # 25 % of bouts lift one foot clearly higher
WALK_MPS = (0.4, 1.5)
RUN_MPS = (1.9, 2.6)  # jogging: a CAVE is about 3 m across
WALK_M = (0.6, 2.2)  # distance of one walk (limited by the room left on the floor)
MIN_TRAVEL_S = 0.8  # a walk shorter than this is a few steps in place ...
MIN_RUN_S = 0.8  # ... and so is a run shorter than this
JOG_MIN_MPS = 1.3  # a run short of room slows down to a jog, not slower
RUN_EXTRA_M = 0.2  # a run may take the person this much further from the start than a walk
WALK_RAMP_S, RUN_RAMP_S = 0.6, 1.0  # speeding up from standing / slowing down to a stop
TURN_RATE_DPS = 150.0  # people turn on the spot at up to ~150 deg/s
STEER_PROB = 0.2  # marching bouts that steer


def travel_duration_s(dist_m: float, speed_mps: float, run: bool) -> float:
    """How long a walk or run at ``speed_mps`` takes to cover ``dist_m`` with its speed-up and
    slow-down (each ``*_RAMP_S``, at most a third of the bout; see ``stepping._path``)."""
    ramp = RUN_RAMP_S if run else WALK_RAMP_S
    cruise = dist_m / max(speed_mps, 1e-6)
    return cruise + ramp if cruise + ramp >= 3.0 * ramp else 1.5 * cruise


def pick(rng: np.random.Generator, weights: dict[str, float]) -> str:
    names = list(weights)
    p = np.array([weights[n] for n in names], dtype=np.float64)
    return str(rng.choice(names, p=p / p.sum()))


def _mostly(rng: np.random.Generator, common: tuple[float, float], full: tuple[float, float]) -> float:
    return float(rng.uniform(*common)) if rng.random() < 0.7 else float(rng.uniform(*full))


def stepping_kwargs(rng: np.random.Generator, action: str, behaviour: str) -> dict[str, Any]:
    """Segment parameters of one stepping bout (forward / left / right) of ``behaviour``."""
    kw: dict[str, Any] = {"behaviour": behaviour, "blend_s": float(rng.uniform(0.1, 0.4))}
    if behaviour in ("walk", "run"):
        kw["travel_mps"] = float(rng.uniform(*(WALK_MPS if behaviour == "walk" else RUN_MPS)))
        kw["irregularity"] = float(rng.uniform(0.0, 0.08))
        kw["arm_swing_deg"] = float(rng.uniform(*ARM_SWING_DEG))
        return kw
    kw["cadence_steps_per_s"] = _mostly(rng, (1.2, 2.4), CADENCE_SPS)
    if action == "forward":
        kw["knee_lift_m"] = _mostly(rng, (0.05, 0.22), KNEE_LIFT_M)
        kw["arm_swing_deg"] = 0.0 if rng.random() < 0.2 else float(rng.uniform(*ARM_SWING_DEG))
        if rng.random() < 0.25:
            kw["slide_m"] = float(rng.uniform(*SLIDE_M))
        if rng.random() < 0.25:
            kw["travel_mps"] = float(rng.uniform(*MARCH_TRAVEL_MPS))
        if rng.random() < STEER_PROB:
            kw["turn_deg"] = float(rng.uniform(-45.0, 45.0))
    else:
        kw["step_width_m"] = float(rng.uniform(*STEP_WIDTH_M))
        kw["arm_swing_deg"] = float(rng.uniform(0.0, 15.0))
        if behaviour != "shuffle":
            kw["knee_lift_m"] = float(rng.uniform(*SIDE_LIFT_M))
    if rng.random() < PAUSE_BOUT_PROB and behaviour not in ("walk", "run"):
        kw["pause_prob"] = float(rng.uniform(*PAUSE_PROB))
        kw["pause_s"] = (0.2, float(rng.uniform(*PAUSE_MAX_S)))
    kw["irregularity"] = (
        float(rng.uniform(*IRREGULARITY)) if rng.random() < 0.3 else float(rng.uniform(0.0, 0.06))
    )
    if rng.random() < 0.25:
        kw["asymmetry"] = float(math.exp(rng.uniform(math.log(ASYMMETRY[0]), math.log(ASYMMETRY[1]))))
    return kw


def still_kwargs(rng: np.random.Generator, behaviour: str) -> dict[str, Any]:
    """Segment parameters of one still segment showing ``behaviour``."""
    kw: dict[str, Any] = {"blend_s": float(rng.uniform(0.1, 0.4))}
    if behaviour != "idle":
        kw["behaviour"] = behaviour
        kw["intensity"] = float(rng.uniform(0.0, 1.0))
    return kw


def turn_deg(rng: np.random.Generator, duration_s: float) -> float:
    """A turn on the spot that fits ``duration_s`` at a human turning rate."""
    max_turn = float(np.clip(TURN_RATE_DPS * duration_s, 20.0, 180.0))
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(20.0, max_turn))
