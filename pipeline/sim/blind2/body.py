"""The blind2 person: segment lengths, head points and stance, drawn from anthropometry.

Height H is uniform in 1.48–1.98 m. Each segment is an anthropometric fraction of H times its own
random factor (a normal about 1 with sd 3–8 %, clipped at 3 sd): thigh 0.245 H, shank 0.246 H,
ankle height 0.046 H (clipped to 7–9 cm), pelvis-to-shoulder 0.282 H, hip-joint spacing 0.105 H,
shoulder spacing 0.213 H, upper arm 0.186 H, forearm 0.146 H. The head is a rigid set of points
(nose, eyes, ears) above the shoulder midpoint. The stance width (ankle spacing) is the hip
spacing plus −3…+7 cm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind2.profiles import DEG

HEIGHT_RANGE_M = (1.48, 1.98)
ANKLE_HEIGHT_RANGE_M = (0.07, 0.09)
HEAD_POINTS = ("nose", "l_eye", "r_eye", "l_ear", "r_ear")  # rows of Body.head_m


@dataclass(frozen=True, slots=True, eq=False)
class Body:
    """One person's fixed geometry (metres, radians).

    head_m: (5, 3) the HEAD_POINTS in the head frame (x right, y forward, z up), whose origin is
    the shoulder midpoint. toe_out_rad: how far each knee points outward of the facing.
    stance_width_m: the ankle spacing when standing.
    """

    height_m: float
    thigh_m: float
    shank_m: float
    ankle_height_m: float
    trunk_m: float
    hip_width_m: float
    shoulder_width_m: float
    upper_arm_m: float
    forearm_m: float
    toe_out_rad: float
    head_m: NDArray[np.float64]
    stance_width_m: float

    def __post_init__(self) -> None:
        if not (math.isfinite(self.height_m) and 1.0 <= self.height_m <= 2.5):
            raise ValueError(f"height_m must be between 1.0 and 2.5 m, got {self.height_m}")
        for name in ("thigh_m", "shank_m", "trunk_m", "hip_width_m", "shoulder_width_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 < value < self.height_m / 2):
                raise ValueError(f"{name} must be positive and under half the height, got {value}")
        for name in ("upper_arm_m", "forearm_m", "stance_width_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and 0.0 < value < self.height_m / 2):
                raise ValueError(f"{name} must be positive and under half the height, got {value}")
        lo, hi = ANKLE_HEIGHT_RANGE_M
        if not (math.isfinite(self.ankle_height_m) and lo <= self.ankle_height_m <= hi):
            raise ValueError(f"ankle_height_m must be between {lo} and {hi} m, got {self.ankle_height_m}")
        if not (math.isfinite(self.toe_out_rad) and 0.0 <= self.toe_out_rad <= 30 * DEG):
            raise ValueError(f"toe_out_rad must be between 0 and 30 degrees, got {self.toe_out_rad}")
        head = np.asarray(self.head_m)
        if head.shape != (len(HEAD_POINTS), 3) or not np.all(np.isfinite(head)):
            raise ValueError(f"head_m must be a finite ({len(HEAD_POINTS)}, 3) array, got shape {head.shape}")


def sample_body(rng: np.random.Generator) -> Body:
    """A random person (the draws, in this order, are part of the generator's output)."""
    H = rng.uniform(*HEIGHT_RANGE_M)

    def f(sd: float = 0.03) -> float:
        return float(np.clip(rng.normal(1.0, sd), 1 - 3 * sd, 1 + 3 * sd))

    s = H / 1.75 * f(0.04)
    thigh = 0.245 * H * f(0.035)
    shank = 0.246 * H * f(0.035)
    ankle_h = float(np.clip(0.046 * H * f(0.05), *ANKLE_HEIGHT_RANGE_M))
    trunk = 0.282 * H * f(0.04)
    hip_w = 0.105 * H * f(0.07)
    sh_w = 0.213 * H * f(0.06)
    upper = 0.186 * H * f(0.04)
    fore = 0.146 * H * f(0.04)
    toe_out = rng.uniform(3, 15) * DEG
    eh = 0.107 * H * f(0.05)
    fy = 0.02 * s  # the head sits slightly in front of the shoulders
    nose = np.array([0.0, fy + 0.105 * s * f(0.05), eh - 0.012 * H])
    l_eye = np.array([-0.032 * s * f(0.06), fy + 0.085 * s, eh + 0.011 * H])
    l_ear = np.array([-0.075 * s * f(0.05), fy, eh])
    mirror = np.array([-1, 1, 1])
    head = np.stack([nose, l_eye, l_eye * mirror, l_ear, l_ear * mirror])
    stance_w = float(hip_w + rng.uniform(-0.03, 0.07))  # ankle separation
    return Body(
        height_m=H,
        thigh_m=thigh,
        shank_m=shank,
        ankle_height_m=ankle_h,
        trunk_m=trunk,
        hip_width_m=hip_w,
        shoulder_width_m=sh_w,
        upper_arm_m=upper,
        forearm_m=fore,
        toe_out_rad=toe_out,
        head_m=head,
        stance_width_m=stance_w,
    )
