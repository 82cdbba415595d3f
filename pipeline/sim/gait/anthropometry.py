"""Body segment lengths from published anthropometric tables, scaled to a height and varied.

Segment lengths are fractions of the standing height H, after the Drillis & Contini
(1966) figure reproduced in Winter, D. A. (2009), *Biomechanics and Motor Control of
Human Movement*, 4th ed., Wiley, Fig. 4.1:

=====================================  ========  ==================================
landmark / length                      x H       used for
=====================================  ========  ==================================
eye height                             0.936     eyes
shoulder (acromion) height             0.818     trunk length (hip centre to shoulder)
hip (greater trochanter) height        0.530     hip joint height
knee height                            0.285     thigh = 0.245 H, shank = 0.246 H
ankle height                           0.039     ankle above the floor
upper arm / forearm                    0.186 / 0.146
shoulder width                         0.259     less 2 x 0.02 H of deltoid: 0.219 H
foot length                            0.152     heel behind / ball ahead of the ankle
=====================================  ========  ==================================

The hip joint centres lie 0.72 of the inter-ASIS breadth apart (Bell, Pedersen & Brand
1990, *Human Movement Science* 9:55-64: each 36 % of the breadth lateral of the mid
line), with the inter-ASIS breadth taken as 0.14 H (about 0.25 m at 1.75 m). Head keypoints
(COCO eyes, ears, nose) sit on a head of bitragion breadth 0.083 H and interpupillary
distance 0.036 H (about 0.145 m and 0.063 m at 1.75 m, adult means of the ANSUR II survey).

Each body draws its height uniformly from the configured range and multiplies every
fraction by its own factor ``exp(N(0, cv))`` (``cv`` about 0.04, the coefficient of
variation of adult segment lengths), so proportions differ between bodies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# Fractions of height H (see the module docstring for the sources).
EYE_HEIGHT = 0.936
SHOULDER_HEIGHT = 0.818
HIP_HEIGHT = 0.530
KNEE_HEIGHT = 0.285
ANKLE_HEIGHT = 0.039
UPPER_ARM = 0.186
FOREARM = 0.146
SHOULDER_WIDTH = 0.259 - 2 * 0.02
FOOT_LENGTH = 0.152
ASIS_BREADTH = 0.14
HJC_LATERAL = 0.36  # Bell et al. (1990): each hip centre 36 % of the ASIS breadth off the mid line
BITRAGION = 0.083
INTERPUPILLARY = 0.036
# The foot's heel lies 0.22 and its ball (metatarsal heads) 0.50 foot lengths from below the ankle.
HEEL_BACK = 0.22
BALL_FORWARD = 0.50


@dataclass(frozen=True, slots=True)
class BodyConfig:
    """How bodies are drawn: height range (m) and the spread of their proportions."""

    height_min_m: float = 1.40
    height_max_m: float = 2.05
    proportion_cv: float = 0.04

    def __post_init__(self) -> None:
        if not 0.5 < self.height_min_m <= self.height_max_m < 3.0:
            raise ValueError(
                f"heights must satisfy 0.5 < min <= max < 3 m, got {self.height_min_m}..{self.height_max_m}"
            )
        if not 0.0 <= self.proportion_cv < 0.2:
            raise ValueError(f"proportion_cv must be in [0, 0.2), got {self.proportion_cv}")


@dataclass(frozen=True, slots=True)
class Body:
    """One person's segment lengths in metres."""

    height_m: float
    thigh_m: float
    shank_m: float
    ankle_height_m: float
    heel_back_m: float
    ball_forward_m: float
    hip_width_m: float  # between the hip joint centres
    trunk_m: float  # mid-hip to mid-shoulder
    shoulder_width_m: float
    upper_arm_m: float
    forearm_m: float
    neck_m: float  # mid-shoulder to the head centre (mid-ears)
    ear_width_m: float
    eye_width_m: float
    eye_forward_m: float  # eyes ahead of the ear line
    eye_up_m: float  # eyes above the ear line
    nose_forward_m: float
    nose_up_m: float  # negative: below the ear line

    def __post_init__(self) -> None:
        for name in self.__slots__:  # type: ignore[attr-defined]
            value = getattr(self, name)
            if name not in ("nose_up_m", "eye_up_m") and not value > 0:
                raise ValueError(f"{name} must be positive, got {value}")

    @property
    def leg_m(self) -> float:
        return self.thigh_m + self.shank_m


def make_body(height_m: float, factors: np.ndarray | None = None) -> Body:
    """The body of the given height; ``factors`` (12,) scale the length groups (1 = the table)."""
    f = np.ones(12) if factors is None else np.asarray(factors, dtype=float)
    if f.shape != (12,) or not np.all(f > 0):
        raise ValueError(f"factors must be 12 positive numbers, got {f}")
    h = float(height_m)
    foot = FOOT_LENGTH * h * f[3]
    head = f[10]
    return Body(
        height_m=h,
        thigh_m=(HIP_HEIGHT - KNEE_HEIGHT) * h * f[0],
        shank_m=(KNEE_HEIGHT - ANKLE_HEIGHT) * h * f[1],
        ankle_height_m=ANKLE_HEIGHT * h * f[2],
        heel_back_m=HEEL_BACK * foot,
        ball_forward_m=BALL_FORWARD * foot,
        hip_width_m=2 * HJC_LATERAL * ASIS_BREADTH * h * f[4],
        trunk_m=(SHOULDER_HEIGHT - HIP_HEIGHT) * h * f[5],
        shoulder_width_m=SHOULDER_WIDTH * h * f[6],
        upper_arm_m=UPPER_ARM * h * f[7],
        forearm_m=FOREARM * h * f[8],
        # Ear level lies about 0.011 H below the eyes; the neck reaches from the shoulders to it.
        neck_m=(EYE_HEIGHT - 0.011 - SHOULDER_HEIGHT) * h * f[9],
        ear_width_m=BITRAGION * h * head,
        eye_width_m=INTERPUPILLARY * h * head,
        eye_forward_m=0.047 * h * head,
        eye_up_m=0.011 * h * head,
        nose_forward_m=0.060 * h * head,
        nose_up_m=-0.012 * h * head,
    )


def sample_body(config: BodyConfig, rng: np.random.Generator) -> Body:
    """A random body: uniform height, every length group varied by ``exp(N(0, cv))``."""
    height = rng.uniform(config.height_min_m, config.height_max_m)
    factors = np.exp(rng.normal(0.0, config.proportion_cv, 12))
    return make_body(height, factors)
