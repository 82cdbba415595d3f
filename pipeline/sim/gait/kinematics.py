"""Joint angles to joint positions: forward kinematics of the body, and a two-bone leg IK.

A pose is one row of ``NCH`` angle channels (radians, :class:`Ch`). Body-local axes:
x to the person's right, y forward, z up; the world (CAVE) frame has yaw 0 facing +Y and
yaw counter-clockwise seen from above, as SPEC.md says.

- Pelvis: the mid-point of the hip joint centres, oriented by yaw + pelvic rotation,
  obliquity and anterior tilt. Hip joints lie half the hip width to each side.
- Legs: each leg bends in the sagittal and frontal planes of the heading. ``HIP_FLEX`` is
  the thigh's angle ahead of the vertical, ``HIP_ABD`` its outward tilt, ``KNEE`` the
  flexion between thigh and shank, ``ANKLE`` dorsiflexion of the foot against the shank.
  The foot points along its own yaw (``FOOT_YAW_*``, world yaw, so a planted foot keeps its
  direction while the body turns over it, the hip rotating); its pitch (toe up positive)
  is ``HIP_FLEX - KNEE + ANKLE``; it never rolls. It has a heel point and a ball point on
  the sole, ``ankle_height`` below the ankle.
- Trunk: from the pelvis centre up ``trunk_m``, leaning forward / sideways and twisted
  against the heading; the shoulders hang off its top, the head (mid-ears) ``neck_m`` above.
- Arms: ``SHOULDER_FLEX`` swings the upper arm forward from hanging, ``SHOULDER_ABD``
  outward, ``ELBOW`` flexes the forearm further in the same plane.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.gait.anthropometry import Body
from pipeline.skeleton import NUM_JOINTS, J

F64 = NDArray[np.float64]


class Ch(IntEnum):
    """Pose channels; the legs and arms have a left (``_L``) and right (``_R = _L + 1``) entry."""

    YAW = 0
    PELVIS_TILT = 1
    PELVIS_OBLIQUITY = 2
    PELVIS_ROTATION = 3
    TRUNK_LEAN = 4
    TRUNK_SIDE = 5
    TRUNK_TWIST = 6
    HEAD_YAW = 7
    HEAD_PITCH = 8
    HIP_FLEX_L = 9
    HIP_FLEX_R = 10
    HIP_ABD_L = 11
    HIP_ABD_R = 12
    KNEE_L = 13
    KNEE_R = 14
    ANKLE_L = 15
    ANKLE_R = 16
    FOOT_YAW_L = 17
    FOOT_YAW_R = 18
    SHOULDER_FLEX_L = 19
    SHOULDER_FLEX_R = 20
    SHOULDER_ABD_L = 21
    SHOULDER_ABD_R = 22
    ELBOW_L = 23
    ELBOW_R = 24


NCH = len(Ch)
LEFT, RIGHT = 0, 1
SIDE_SIGN = (-1.0, 1.0)  # the person's left is -x in the body frame


def rot_x(a: F64) -> F64:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(a: F64) -> F64:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(a: F64) -> F64:
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _apply(r: F64, v: F64 | tuple[float, float, float]) -> F64:
    """(T, 3, 3) @ (T, 3) or a constant (3,) vector."""
    vec = np.asarray(v, dtype=float)
    if vec.ndim == 1:
        return np.einsum("tij,j->ti", r, vec)
    return np.einsum("tij,tj->ti", r, vec)


DOWN = (0.0, 0.0, -1.0)
UP = (0.0, 0.0, 1.0)


@dataclass(frozen=True, slots=True)
class RelativePose:
    """Forward kinematics with the pelvis centre at the origin (world axes, metres).

    hip, knee, ankle, heel, ball: (T, 2, 3) [left, right]; foot_pitch: (T, 2) rad;
    upper: (T, 17, 3) every COCO joint from this pass (the legs as the angles put them).
    """

    hip: F64
    knee: F64
    ankle: F64
    heel: F64
    ball: F64
    foot_pitch: F64
    foot_yaw: F64
    upper: F64


def forward(body: Body, a: F64) -> RelativePose:
    """Joint positions relative to the pelvis centre for angle rows ``a`` (T, NCH)."""
    if a.ndim != 2 or a.shape[1] != NCH:
        raise ValueError(f"pose angles must have shape (T, {NCH}), got {a.shape}")
    t = a.shape[0]
    yaw = a[:, Ch.YAW]
    r_pelvis = rot_z(yaw + a[:, Ch.PELVIS_ROTATION]) @ rot_y(a[:, Ch.PELVIS_OBLIQUITY])
    r_pelvis = r_pelvis @ rot_x(-a[:, Ch.PELVIS_TILT])
    hip = np.empty((t, 2, 3))
    knee = np.empty((t, 2, 3))
    ankle = np.empty((t, 2, 3))
    heel = np.empty((t, 2, 3))
    ball = np.empty((t, 2, 3))
    pitch = np.empty((t, 2))
    for side in (LEFT, RIGHT):
        sign = SIDE_SIGN[side]
        hip[:, side] = _apply(r_pelvis, (sign * body.hip_width_m / 2, 0.0, 0.0))
        r_leg = rot_z(yaw) @ rot_y(-sign * a[:, Ch.HIP_ABD_L + side])
        flex = a[:, Ch.HIP_FLEX_L + side]
        shank_angle = flex - a[:, Ch.KNEE_L + side]
        knee[:, side] = hip[:, side] + body.thigh_m * _apply(r_leg @ rot_x(flex), DOWN)
        ankle[:, side] = knee[:, side] + body.shank_m * _apply(r_leg @ rot_x(shank_angle), DOWN)
        pitch[:, side] = shank_angle + a[:, Ch.ANKLE_L + side]
        r_foot = rot_z(a[:, Ch.FOOT_YAW_L + side]) @ rot_x(pitch[:, side])
        heel[:, side] = ankle[:, side] + _apply(r_foot, (0.0, -body.heel_back_m, -body.ankle_height_m))
        ball[:, side] = ankle[:, side] + _apply(r_foot, (0.0, body.ball_forward_m, -body.ankle_height_m))

    r_trunk = rot_z(yaw + a[:, Ch.TRUNK_TWIST]) @ rot_y(a[:, Ch.TRUNK_SIDE]) @ rot_x(-a[:, Ch.TRUNK_LEAN])
    neck = _apply(r_trunk, (0.0, 0.0, body.trunk_m))
    out = np.empty((t, NUM_JOINTS, 3))
    r_head = r_trunk @ rot_z(a[:, Ch.HEAD_YAW]) @ rot_x(-a[:, Ch.HEAD_PITCH])
    head = neck + _apply(r_head, (0.0, 0.0, body.neck_m))
    out[:, J["nose"]] = head + _apply(r_head, (0.0, body.nose_forward_m, body.nose_up_m))
    for side, name in ((LEFT, "l"), (RIGHT, "r")):
        sign = SIDE_SIGN[side]
        out[:, J[f"{name}_eye"]] = head + _apply(
            r_head, (sign * body.eye_width_m / 2, body.eye_forward_m, body.eye_up_m)
        )
        out[:, J[f"{name}_ear"]] = head + _apply(r_head, (sign * body.ear_width_m / 2, 0.0, 0.0))
        shoulder = neck + _apply(r_trunk, (sign * body.shoulder_width_m / 2, 0.0, 0.0))
        r_arm = r_trunk @ rot_y(-sign * a[:, Ch.SHOULDER_ABD_L + side])
        sflex = a[:, Ch.SHOULDER_FLEX_L + side]
        elbow = shoulder + body.upper_arm_m * _apply(r_arm @ rot_x(sflex), DOWN)
        wrist = elbow + body.forearm_m * _apply(r_arm @ rot_x(sflex + a[:, Ch.ELBOW_L + side]), DOWN)
        out[:, J[f"{name}_shoulder"]] = shoulder
        out[:, J[f"{name}_elbow"]] = elbow
        out[:, J[f"{name}_wrist"]] = wrist
        out[:, J[f"{name}_hip"]] = hip[:, side]
        out[:, J[f"{name}_knee"]] = knee[:, side]
        out[:, J[f"{name}_ankle"]] = ankle[:, side]
    return RelativePose(hip, knee, ankle, heel, ball, pitch, a[:, Ch.FOOT_YAW_L : Ch.FOOT_YAW_R + 1], out)


def two_bone_ik(hip: F64, target: F64, pole: F64, thigh: float, shank: float) -> tuple[F64, F64]:
    """Knee and ankle (T, 3) of a leg from ``hip`` reaching for ``target`` (T, 3).

    The knee bends towards ``pole`` (T, 3), a direction from the hip; a target beyond reach
    is clamped to the straight leg along the hip-target line.
    """
    d_vec = target - hip
    d = np.linalg.norm(d_vec, axis=-1)
    reach = thigh + shank
    d_c = np.clip(d, abs(thigh - shank) + 1e-6, reach * (1 - 1e-9))
    u = d_vec / np.maximum(d, 1e-12)[:, None]
    n = pole - np.sum(pole * u, axis=-1, keepdims=True) * u
    n_len = np.linalg.norm(n, axis=-1)
    n = n / np.maximum(n_len, 1e-12)[:, None]
    x = (thigh**2 - shank**2 + d_c**2) / (2 * d_c)
    r = np.sqrt(np.maximum(thigh**2 - x**2, 0.0))
    knee = hip + x[:, None] * u + r[:, None] * n
    ankle = hip + d_c[:, None] * u
    return knee, ankle
