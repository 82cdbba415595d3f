"""One simulated person: body proportions (:class:`Body`) and way of moving (:class:`Style`).

Segment lengths are fractions of standing height after Drillis & Contini (1966), as tabulated in
Winter, *Biomechanics and Motor Control of Human Movement*, fig. 4.1: hip joint at 0.530 H, knee
0.285 H, ankle 0.039 H, shoulder 0.818 H, upper arm 0.186 H, forearm 0.146 H. Widths are the
separations of the COCO keypoints (joint centres, acromia), narrower than Drillis' body breadths.
Each person's ratios are drawn a few percent around these values.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from pipeline.errors import InputError
from pipeline.sim.blind.timing import LAWS

# name: (default, low, high) as fractions of standing height.
BODY_RATIOS: dict[str, tuple[float, float, float]] = {
    "thigh_ratio": (0.245, 0.215, 0.275),  # hip joint to knee (0.530 − 0.285)
    "shank_ratio": (0.246, 0.216, 0.276),  # knee to ankle (0.285 − 0.039)
    "ankle_ratio": (0.039, 0.032, 0.046),  # ankle joint above the floor
    "trunk_ratio": (0.288, 0.255, 0.320),  # hip midpoint to shoulder midpoint (0.818 − 0.530)
    "neck_ratio": (0.115, 0.095, 0.135),  # shoulder midpoint to the head's centre (ear level)
    "hip_width_ratio": (0.115, 0.090, 0.140),
    "shoulder_width_ratio": (0.225, 0.190, 0.260),
    "upper_arm_ratio": (0.186, 0.165, 0.207),
    "forearm_ratio": (0.146, 0.128, 0.164),
    "head_ratio": (1.0, 0.85, 1.15),  # scale of the face (eyes, ears, nose) around the head centre
}
HEIGHT_RANGE_M = (1.48, 1.98)  # what the generator draws; Body itself accepts 1.2–2.2 m


@dataclass(frozen=True, slots=True)
class Body:
    """A person's size. height_m: standing height in metres; the ratios are fractions of it."""

    height_m: float
    thigh_ratio: float = BODY_RATIOS["thigh_ratio"][0]
    shank_ratio: float = BODY_RATIOS["shank_ratio"][0]
    ankle_ratio: float = BODY_RATIOS["ankle_ratio"][0]
    trunk_ratio: float = BODY_RATIOS["trunk_ratio"][0]
    neck_ratio: float = BODY_RATIOS["neck_ratio"][0]
    hip_width_ratio: float = BODY_RATIOS["hip_width_ratio"][0]
    shoulder_width_ratio: float = BODY_RATIOS["shoulder_width_ratio"][0]
    upper_arm_ratio: float = BODY_RATIOS["upper_arm_ratio"][0]
    forearm_ratio: float = BODY_RATIOS["forearm_ratio"][0]
    head_ratio: float = BODY_RATIOS["head_ratio"][0]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.height_m) and 1.2 <= self.height_m <= 2.2):
            raise InputError(f"height_m must be between 1.2 and 2.2 m, got {self.height_m}")
        for name, (_, lo, hi) in BODY_RATIOS.items():
            v = getattr(self, name)
            if not (math.isfinite(v) and lo <= v <= hi):
                raise InputError(f"{name} must be between {lo} and {hi}, got {v}")

    def length(self, ratio_name: str) -> float:
        """A ratio field as metres."""
        return float(getattr(self, ratio_name)) * self.height_m


# The segments stacked from the floor to the head's centre; their sum stays at the default's.
VERTICAL_CHAIN = ("ankle_ratio", "shank_ratio", "thigh_ratio", "trunk_ratio", "neck_ratio")


def sample_body(rng: np.random.Generator, height_m: float) -> Body:
    """A body of ``height_m`` with each ratio drawn about ±3 % (sd) around its default.

    The vertical chain (ankle, shank, thigh, trunk, neck) is then rescaled so that the head sits
    where ``height_m`` puts it: people differ in proportions (long legs, long trunk), not in how
    tall their stated height makes them.
    """
    kw: dict[str, float] = {}
    for name, (default, lo, hi) in BODY_RATIOS.items():
        kw[name] = float(np.clip(default * rng.normal(1.0, 0.03), lo, hi))
    target = sum(BODY_RATIOS[n][0] for n in VERTICAL_CHAIN)
    scale = target / sum(kw[n] for n in VERTICAL_CHAIN)
    for n in VERTICAL_CHAIN:
        _, lo, hi = BODY_RATIOS[n]
        kw[n] = float(np.clip(kw[n] * scale, lo, hi))
    return Body(height_m=height_m, **kw)


# Style parameters: name -> (low, high); sample_style draws uniformly in this box (some log-uniform
# or with a probability of zero, see there) and Style refuses values outside it.
STYLE_BOUNDS: dict[str, tuple[float, float]] = {
    "cadence_hz": (0.6, 2.4),  # marching steps (foot lifts) per second
    "march_lift_m": (0.03, 0.25),  # ankle rise of a marching step
    "lift_jitter": (0.0, 0.2),  # step-to-step relative variation of the lift
    "timing_jitter": (0.0, 0.12),  # step-to-step relative variation of swing time and period
    "swing_frac": (0.5, 0.9),  # swing time / step period while marching
    "max_swing_s": (0.45, 1.1),  # a slow marcher's swing is at most this long
    "peak_frac": (0.3, 0.6),  # fraction of the swing spent rising
    "hold_frac": (0.0, 0.3),  # fraction of the swing held at the top
    "fore_aft": (-0.6, 0.3),  # ankle's fore/aft excursion mid-swing as a fraction of the lift (− heel back)
    "hesitation_p": (0.0, 0.15),  # chance of an extra pause before a marching step
    "arm_swing_deg": (0.0, 35.0),  # arm swing amplitude while marching
    "arm_lag_s": (0.0, 0.12),  # arms lag the legs by this much
    "sway_gain": (0.15, 0.8),  # how far the pelvis moves over the supporting foot (1 = all the way)
    "sway_sigma_s": (0.05, 0.2),  # smoothness (and anticipation) of that weight transfer
    "bob_m": (0.0, 0.03),  # pelvis dip after each touch-down
    "pelvis_rot_deg": (0.0, 6.0),  # pelvis yaw oscillation with the legs
    "pelvis_obliq_deg": (0.0, 4.0),  # swing-side hip hike
    "trunk_lean_deg": (-3.0, 10.0),  # habitual forward lean
    "trunk_roll_deg": (-2.0, 5.0),  # trunk lean towards the loaded foot (negative: away)
    "drift_m": (0.0, 0.015),  # forward creep per marching step
    "side_width_m": (0.10, 0.40),  # side-step size
    "side_lift_m": (0.02, 0.12),  # ankle rise of a side step
    "side_swing_s": (0.25, 0.7),  # duration of a side step's swing
    "side_pause_s": (0.2, 0.9),  # typical pause between the steps of a side-step bout
    "stance_width_ratio": (0.07, 0.16),  # ankle separation standing, fraction of height
    "toe_out_deg": (0.0, 15.0),  # knees point this much outwards of the facing direction
    "knee_bend_deg": (3.0, 12.0),  # standing knee flexion
    "fore_offset_m": (-0.02, 0.05),  # hips ahead of the ankles standing
    "arm_abd_deg": (3.0, 15.0),  # arms' rest abduction
    "elbow_deg": (5.0, 30.0),  # elbows' rest flexion
    "head_pitch_deg": (-5.0, 12.0),  # habitual head pitch (positive: looking down)
    "sway_m": (0.002, 0.01),  # standing postural sway (sd)
}


@dataclass(frozen=True, slots=True)
class Style:
    """How one person moves; every number within STYLE_BOUNDS (units in the names)."""

    cadence_hz: float = 1.5
    march_lift_m: float = 0.10
    lift_jitter: float = 0.08
    timing_jitter: float = 0.05
    swing_frac: float = 0.7
    max_swing_s: float = 0.8
    peak_frac: float = 0.45
    hold_frac: float = 0.05
    fore_aft: float = -0.2
    hesitation_p: float = 0.05
    arm_swing_deg: float = 15.0
    arm_lag_s: float = 0.05
    sway_gain: float = 0.4
    sway_sigma_s: float = 0.1
    bob_m: float = 0.01
    pelvis_rot_deg: float = 3.0
    pelvis_obliq_deg: float = 1.5
    trunk_lean_deg: float = 3.0
    trunk_roll_deg: float = 2.0
    drift_m: float = 0.0
    side_width_m: float = 0.25
    side_lift_m: float = 0.05
    side_swing_s: float = 0.45
    side_pause_s: float = 0.45
    stance_width_ratio: float = 0.11
    toe_out_deg: float = 8.0
    knee_bend_deg: float = 5.0
    fore_offset_m: float = 0.02
    arm_abd_deg: float = 8.0
    elbow_deg: float = 12.0
    head_pitch_deg: float = 3.0
    sway_m: float = 0.005
    law: str = "minjerk"
    right_handed: bool = True

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name not in STYLE_BOUNDS:
                continue
            v = getattr(self, f.name)
            lo, hi = STYLE_BOUNDS[f.name]
            if not (isinstance(v, int | float) and math.isfinite(v) and lo <= v <= hi):
                raise InputError(f"{f.name} must be between {lo} and {hi}, got {v!r}")
        if self.law not in LAWS:
            raise InputError(f"law must be one of {list(LAWS)}, got {self.law!r}")
        if self.peak_frac + self.hold_frac > 0.8:
            raise InputError(
                f"peak_frac + hold_frac must leave at least 20 % of a swing to come down, "
                f"got {self.peak_frac} + {self.hold_frac}"
            )


def sample_style(
    rng: np.random.Generator, cadence_hz: float | None = None, march_lift_m: float | None = None
) -> Style:
    """A random person's style; cadence and lift may be given (a set spreads them over the range)."""
    kw: dict[str, float] = {name: float(rng.uniform(lo, hi)) for name, (lo, hi) in STYLE_BOUNDS.items()}
    lo, hi = STYLE_BOUNDS["cadence_hz"]
    kw["cadence_hz"] = (
        cadence_hz if cadence_hz is not None else float(np.exp(rng.uniform(np.log(lo), np.log(hi))))
    )
    lo, hi = STYLE_BOUNDS["march_lift_m"]
    kw["march_lift_m"] = march_lift_m if march_lift_m is not None else float(rng.uniform(lo, hi))
    kw["hold_frac"] = min(kw["hold_frac"], 0.8 - kw["peak_frac"])
    if rng.random() < 0.3:  # some people keep their arms still
        kw["arm_swing_deg"] = float(rng.uniform(0.0, 4.0))
    if rng.random() < 0.6:  # most stay where they are
        kw["drift_m"] = 0.0
    if rng.random() < 0.5:
        kw["hold_frac"] = 0.0
    law = str(rng.choice(LAWS))
    return Style(**kw, law=law, right_handed=bool(rng.random() < 0.85))  # type: ignore[arg-type]
