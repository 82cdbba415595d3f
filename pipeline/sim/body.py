"""Bodies of simulated users: proportions, personal motion style and the kinematics that pose them.

Proportions follow Drillis & Contini's segment fractions of body height (ankle 0.039 H,
knee 0.285 H, hip 0.530 H, shoulder 0.818 H, upper arm 0.186 H, forearm to wrist
0.146 H), varied per person (:func:`sample_body`): a longer or shorter leg (hip 0.50-0.56 H,
the knee splitting it 0.47-0.53), the trunk taking up the rest, arms 0.30-0.36 H, shoulders
0.20-0.25 H and hips 0.09-0.13 H wide.

Local body frame (used before a pose is placed in the CAVE): x to the person's right,
y forward, z up, origin on the floor under the pelvis.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

F64 = NDArray[np.float64]

HEIGHT_RANGE = (1.40, 2.05)


@dataclass(frozen=True, slots=True)
class BodyParams:
    """Anthropometry of one simulated person (all metres).

    height_m: standing height.
    ankle_height_m, knee_height_m, hip_height_m, shoulder_height_m, ear_height_m: joint heights
        above the floor when standing upright.
    shoulder_width_m: distance between the two shoulder keypoints.
    hip_width_m: distance between the two hip keypoints.
    upper_arm_m: shoulder to elbow; forearm_m: elbow to wrist.
    """

    height_m: float
    ankle_height_m: float
    knee_height_m: float
    hip_height_m: float
    shoulder_height_m: float
    ear_height_m: float
    shoulder_width_m: float
    hip_width_m: float
    upper_arm_m: float
    forearm_m: float

    def __post_init__(self) -> None:
        values = {name: float(getattr(self, name)) for name in self.__slots__}  # type: ignore[attr-defined]
        for name, v in values.items():
            if not np.isfinite(v) or v <= 0:
                raise InputError(f"body {name} must be a positive number, got {v}")
            object.__setattr__(self, name, v)
        order = (
            "ankle_height_m",
            "knee_height_m",
            "hip_height_m",
            "shoulder_height_m",
            "ear_height_m",
            "height_m",
        )
        heights = [values[n] for n in order]
        if any(a >= b for a, b in itertools.pairwise(heights)):
            raise InputError(f"body joint heights must increase {' < '.join(order)}, got {heights}")
        if not 0.8 <= values["height_m"] <= 2.5:
            raise InputError(f"body height_m must be in [0.8, 2.5], got {values['height_m']}")

    @property
    def thigh_m(self) -> float:
        return self.hip_height_m - self.knee_height_m

    @property
    def shin_m(self) -> float:
        return self.knee_height_m - self.ankle_height_m

    @property
    def torso_m(self) -> float:
        """Pelvis centre to shoulder centre."""
        return self.shoulder_height_m - self.hip_height_m

    @property
    def neck_m(self) -> float:
        """Shoulder centre to head centre (between the ears)."""
        return self.ear_height_m - self.shoulder_height_m

    @property
    def head_scale(self) -> float:
        """Scale of the face keypoint offsets (1 for a 1.75 m person; heads vary less than bodies)."""
        return float(np.sqrt(self.height_m / 1.75))


def body_from_height(height_m: float) -> BodyParams:
    """The average proportions for a given height."""
    h = float(height_m)
    return BodyParams(
        height_m=h,
        ankle_height_m=0.039 * h,
        knee_height_m=0.285 * h,
        hip_height_m=0.530 * h,
        shoulder_height_m=0.818 * h,
        ear_height_m=0.925 * h,
        shoulder_width_m=0.225 * h,
        hip_width_m=0.110 * h,
        upper_arm_m=0.186 * h,
        forearm_m=0.146 * h,
    )


def sample_body(rng: np.random.Generator, height_range: tuple[float, float] = HEIGHT_RANGE) -> BodyParams:
    """A random person: height uniform in ``height_range``, proportions varied (module docstring)."""
    lo, hi = (float(v) for v in height_range)
    if not 0.8 <= lo <= hi <= 2.5:
        raise InputError(f"height_range must satisfy 0.8 <= min <= max <= 2.5, got {height_range}")
    h = float(rng.uniform(lo, hi))
    u = rng.uniform
    ankle = 0.039 * h * float(u(0.85, 1.15))
    hip = h * float(u(0.50, 0.56))
    knee = ankle + (hip - ankle) * float(u(0.47, 0.53))
    arm = h * float(u(0.30, 0.36))
    upper = arm * float(u(0.53, 0.58))
    return BodyParams(
        height_m=h,
        ankle_height_m=ankle,
        knee_height_m=knee,
        hip_height_m=hip,
        shoulder_height_m=h * float(u(0.805, 0.83)),
        ear_height_m=h * float(u(0.918, 0.932)),
        shoulder_width_m=h * float(u(0.20, 0.25)),
        hip_width_m=h * float(u(0.09, 0.13)),
        upper_arm_m=upper,
        forearm_m=arm - upper,
    )


REST_ARMS: tuple[str, ...] = ("hanging", "clasped")


@dataclass(frozen=True, slots=True)
class MotionStyle:
    """How one person moves: the per-user randomness of the simulator.

    cadence_steps_per_s: preferred stepping cadence. knee_lift_m: preferred peak ankle rise.
    lift_asymmetry: left-lift multiplier (the right one gets its inverse; the higher-lifting
    foot also swings a little longer).
    step_variation: relative random variation of each step's lift.
    swing_fraction: part of each step's time the foot is in the air (rest: double support).
    step_irregularity: relative random spread of step timing, lift and placement.
    pause_prob: chance that a step is followed by a pause (both feet down 0.2-1.0 s); 0 in
    drawn styles: pauses belong to a bout (``Segment.pause_prob``, drawn by the routines).
    march_slide_m: how far a marching stance foot slides back (negative: forward).
    weight_shift_frac: how far the pelvis moves over the stance foot during a step.
    arm_swing_deg: peak arm swing while marching. elbow_flex_deg: elbow bend at rest.
    rest_arms: ``hanging`` or ``clasped`` (hands together in front).
    sway_m: standing postural sway. stance_width_m: distance between the ankles standing.
    trunk_lean_deg: forward lean. head_forward_m: head ahead of the shoulders.
    gesture_rate_hz: gestures per second while still. look_deg: amplitude of looking around.
    side_step_m: preferred side-step width. side_trail_frac: lift of the trailing foot while
    side-stepping, relative to the leading one. side_shift_frac: how much of a side step the
    pelvis follows. march_drift_mps: creeping forward while marching in place.
    toe_out_deg: knee direction outward of straight ahead. blend_s: transition time.
    cadence_drift: relative slow wandering of cadence within a segment.
    forward_ankle_frac: forward travel of the lifted ankle relative to its rise.
    knee_flex_deg: knee bend when standing.
    """

    cadence_steps_per_s: float = 1.8
    knee_lift_m: float = 0.14
    lift_asymmetry: float = 1.0
    step_variation: float = 0.1
    swing_fraction: float = 0.7
    arm_swing_deg: float = 20.0
    elbow_flex_deg: float = 15.0
    rest_arms: str = "hanging"
    sway_m: float = 0.01
    stance_width_m: float = 0.2
    trunk_lean_deg: float = 3.0
    head_forward_m: float = 0.02
    gesture_rate_hz: float = 0.1
    look_deg: float = 25.0
    side_step_m: float = 0.22
    side_trail_frac: float = 0.3
    side_shift_frac: float = 0.35
    march_drift_mps: float = 0.01
    toe_out_deg: float = 8.0
    blend_s: float = 0.25
    cadence_drift: float = 0.03
    forward_ankle_frac: float = 0.4
    knee_flex_deg: float = 8.0
    step_irregularity: float = 0.01
    pause_prob: float = 0.0
    march_slide_m: float = 0.0
    weight_shift_frac: float = 0.5

    def __post_init__(self) -> None:
        if self.rest_arms not in REST_ARMS:
            raise InputError(f"rest_arms must be one of {REST_ARMS}, got {self.rest_arms!r}")
        for name in self.__slots__:  # type: ignore[attr-defined]
            if name == "rest_arms":
                continue
            v = float(getattr(self, name))
            if not np.isfinite(v):
                raise InputError(f"style {name} must be finite, got {v}")
            object.__setattr__(self, name, v)
        if not 0.2 <= self.swing_fraction <= 1.0:
            raise InputError(f"swing_fraction must be in [0.2, 1], got {self.swing_fraction}")
        if self.cadence_steps_per_s <= 0 or self.lift_asymmetry <= 0:
            raise InputError("cadence_steps_per_s and lift_asymmetry must be > 0")


def sample_style(rng: np.random.Generator) -> MotionStyle:
    """A random personal motion style (ranges chosen to cover how different people step in place).

    A person's own timing irregularity and lift asymmetry are mild; strongly irregular or
    asymmetric bouts are asked for per segment (``Segment.irregularity`` / ``asymmetry``), as the
    random routines do."""
    u = rng.uniform
    return MotionStyle(
        cadence_steps_per_s=float(u(1.0, 2.3)),
        knee_lift_m=float(u(0.05, 0.22)),
        lift_asymmetry=float(np.exp(u(np.log(0.9), np.log(1.1)))),
        step_variation=float(u(0.04, 0.25)),
        swing_fraction=float(u(0.55, 0.9)),
        arm_swing_deg=float(u(0.0, 4.0)) if rng.random() < 0.25 else float(u(8.0, 40.0)),
        elbow_flex_deg=float(u(5.0, 35.0)),
        rest_arms=str(rng.choice(REST_ARMS, p=[0.8, 0.2])),
        sway_m=float(u(0.004, 0.018)),
        stance_width_m=float(u(0.12, 0.28)),
        trunk_lean_deg=float(u(-2.0, 8.0)),
        head_forward_m=float(u(0.0, 0.05)),
        gesture_rate_hz=float(u(0.03, 0.25)),
        look_deg=float(u(8.0, 45.0)),
        side_step_m=float(u(0.10, 0.40)),
        side_trail_frac=float(u(0.0, 0.6)),
        side_shift_frac=float(u(0.2, 0.5)),
        march_drift_mps=float(u(0.0, 0.03)),
        toe_out_deg=float(u(0.0, 15.0)),
        blend_s=float(u(0.1, 0.4)),
        cadence_drift=float(u(0.0, 0.06)),
        forward_ankle_frac=float(u(-0.3, 0.7)),
        knee_flex_deg=float(u(4.0, 14.0)),
        step_irregularity=float(u(0.0, 0.02)),
        march_slide_m=float(u(-0.03, 0.07)) if rng.random() < 0.4 else 0.0,
        weight_shift_frac=float(u(0.3, 0.8)),
    )


# --- kinematics (pure, vectorised over frames) ------------------------------------------------


def rot_z(angle_rad: F64) -> F64:
    """(N,) angles -> (N, 3, 3) rotations about +z (counter-clockwise seen from above)."""
    a = np.asarray(angle_rad, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def rot_x(angle_rad: F64) -> F64:
    """(N,) angles -> (N, 3, 3) rotations about +x (positive tips +y towards +z)."""
    a = np.asarray(angle_rad, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(angle_rad: F64) -> F64:
    """(N,) angles -> (N, 3, 3) rotations about +y (positive tips +z towards +x)."""
    a = np.asarray(angle_rad, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def apply(rot: F64, vec: F64) -> F64:
    """(N, 3, 3) @ (N, 3) or (3,) -> (N, 3)."""
    v = np.asarray(vec, dtype=np.float64)
    if v.ndim == 1:
        return rot @ v
    return np.einsum("nij,nj->ni", rot, v)


def two_bone_ik(root: F64, target: F64, l1: float, l2: float, pole: F64) -> tuple[F64, F64]:
    """Analytic two-bone IK: (N, 3) root and end target, bone lengths, (N, 3) bend direction.

    Returns (middle, end): the middle joint (elbow or knee) bends towards ``pole``; the end is
    the target pulled onto the reachable shell [|l1 - l2|, l1 + l2] if it lies outside.
    """
    d = target - root
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    dir_ = d / np.maximum(dist, 1e-9)
    dist = np.clip(dist, abs(l1 - l2) + 1e-4, (l1 + l2) * 0.9995)
    cos_a = np.clip((l1 * l1 + dist * dist - l2 * l2) / (2.0 * l1 * dist), -1.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a * cos_a)
    p = pole - np.sum(pole * dir_, axis=-1, keepdims=True) * dir_
    pn = np.linalg.norm(p, axis=-1, keepdims=True)
    # Pole parallel to the bone line: any perpendicular will do.
    fallback = np.cross(dir_, np.array([1.0, 0.0, 0.0]))
    fb_norm = np.linalg.norm(fallback, axis=-1, keepdims=True)
    fallback = np.where(fb_norm > 1e-6, fallback / np.maximum(fb_norm, 1e-9), np.array([0.0, 1.0, 0.0]))
    p = np.where(pn > 1e-6, p / np.maximum(pn, 1e-9), fallback)
    middle = root + dir_ * (l1 * cos_a) + p * (l1 * sin_a)
    end = root + dir_ * dist
    return middle, end


def arm_reach(upper_m: float, fore_m: float, elbow_flex_rad: F64) -> F64:
    """Shoulder-wrist distance for an elbow bent by ``elbow_flex_rad`` (0 = straight)."""
    return np.sqrt(upper_m**2 + fore_m**2 + 2.0 * upper_m * fore_m * np.cos(elbow_flex_rad))


# Face keypoints in the head frame (x right, y forward, z up; origin between the ears), metres,
# for a 1.75 m person: nose, l_eye, r_eye, l_ear, r_ear.
FACE_OFFSETS_M = np.array(
    [
        [0.0, 0.105, -0.035],
        [-0.033, 0.088, 0.0],
        [0.033, 0.088, 0.0],
        [-0.075, 0.0, 0.0],
        [0.075, 0.0, 0.0],
    ]
)
