"""Per-sequence body model: segment lengths and widths sampled around anthropometric ratios."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Body:
    """Fixed segment dimensions (metres / radians) of one simulated person."""

    height: float
    thigh: float  # hip joint -> knee joint
    shank: float  # knee joint -> ankle joint
    ankle_h: float  # ankle joint height above the floor with the foot flat
    hip_half: float  # half distance between the hip joint centres
    stance_half: float  # half distance between the ankles in a relaxed stance
    toe_out: float  # outward rotation of each foot relative to the heading
    trunk: float  # mid-hip -> mid-shoulder
    shoulder_half: float  # half distance between the shoulder joint centres
    upper_arm: float  # shoulder -> elbow
    forearm: float  # elbow -> wrist
    neck: float  # mid-shoulder -> head base
    head_scale: float  # scale of the facial key-point layout
    knee_slack: float  # fraction of the full leg length used when standing

    @property
    def leg(self) -> float:
        """Full (straight) leg length hip -> ankle."""
        return self.thigh + self.shank

    @property
    def stand_hip_z(self) -> float:
        """Hip joint height in a relaxed stance."""
        return self.ankle_h + self.leg * self.knee_slack

    @property
    def com_height(self) -> float:
        """Height of the centre of mass used by the inverted pendulum."""
        return 0.555 * self.height

    @property
    def omega(self) -> float:
        """LIPM natural frequency sqrt(g / z_c) in rad/s."""
        return math.sqrt(9.81 / self.com_height)


def sample_body(rng: np.random.Generator) -> Body:
    """Draw a body of 1.45-2.00 m with varied leg/trunk ratio and widths."""
    h = float(rng.uniform(1.45, 2.00))
    leg_ratio = float(rng.uniform(0.94, 1.06))  # long- vs short-legged
    trunk_ratio = float(rng.uniform(0.95, 1.05)) / math.sqrt(leg_ratio)
    thigh = 0.245 * h * leg_ratio * float(rng.uniform(0.97, 1.03))
    shank = 0.246 * h * leg_ratio * float(rng.uniform(0.97, 1.03))
    ankle_h = float(np.clip(0.043 * h * rng.uniform(0.92, 1.08), 0.06, 0.095))
    hip_half = 0.5 * 0.105 * h * float(rng.uniform(0.85, 1.18))
    shoulder_half = 0.5 * 0.205 * h * float(rng.uniform(0.88, 1.12))
    arm_ratio = float(rng.uniform(0.95, 1.05))
    return Body(
        height=h,
        thigh=thigh,
        shank=shank,
        ankle_h=ankle_h,
        hip_half=hip_half,
        stance_half=hip_half * float(rng.uniform(0.8, 1.3)),
        toe_out=math.radians(float(rng.uniform(3.0, 12.0))),
        trunk=0.288 * h * trunk_ratio,
        shoulder_half=shoulder_half,
        upper_arm=0.186 * h * arm_ratio * float(rng.uniform(0.97, 1.03)),
        forearm=0.146 * h * arm_ratio * float(rng.uniform(0.97, 1.03)),
        neck=0.055 * h * float(rng.uniform(0.9, 1.1)),
        head_scale=h / 1.75 * float(rng.uniform(0.93, 1.07)),
        knee_slack=float(rng.uniform(0.975, 0.99)),
    )
