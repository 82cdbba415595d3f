"""Rotation math shared by the mocap converters: quaternions (w, x, y, z), slerp, resampling,
and the placement of a clip in the CAVE frame (floor at z = 0, centred on the floor).

Pure numpy; every function works on whole clips (arrays with a leading time axis).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

F64 = NDArray[np.float64]


def unit_rows(v: F64) -> F64:
    """Each vector of ``v`` (..., 3) scaled to length 1 (a zero vector stays zero)."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-9)


def unit_across(v: F64, s: F64) -> F64:
    """Each vector of ``v`` made orthogonal to the unit vector ``s`` beside it, then of length 1."""
    return unit_rows(v - np.sum(v * s, axis=-1, keepdims=True) * s)


def quat_normalize(q: F64) -> F64:
    """Unit quaternions (..., 4) (w, x, y, z); raises on a zero quaternion."""
    n = np.linalg.norm(q, axis=-1, keepdims=True)
    if np.any(n < 1e-12):
        raise InputError("a quaternion of zero length cannot be a rotation")
    return np.asarray(q / n, dtype=np.float64)


def quat_to_matrix(q: F64) -> F64:
    """Rotation matrices (..., 3, 3) of unit quaternions (..., 4) in (w, x, y, z) order."""
    w, x, y, z = np.moveaxis(quat_normalize(q), -1, 0)
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def quat_mul(a: F64, b: F64) -> F64:
    """Hamilton product a * b of quaternions (..., 4) (w, x, y, z)."""
    aw, ax, ay, az = np.moveaxis(a, -1, 0)
    bw, bx, by, bz = np.moveaxis(b, -1, 0)
    return np.stack(
        [
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        ],
        -1,
    )


def axis_angle_quat(axis: F64, angle_rad: F64) -> F64:
    """Quaternions (T, 4) of rotations by ``angle_rad`` (T,) about one unit ``axis`` (3,)."""
    a = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    half = 0.5 * np.asarray(angle_rad, dtype=np.float64)
    return np.concatenate([np.cos(half)[:, None], np.sin(half)[:, None] * a[None, :]], axis=1)


def slerp(q0: F64, q1: F64, u: F64) -> F64:
    """Spherical interpolation between quaternions (N, 4) at fractions u (N,) in [0, 1]."""
    q0 = quat_normalize(q0)
    q1 = quat_normalize(q1)
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where(dot[:, None] < 0, -q1, q1)  # the short way round
    dot = np.abs(dot).clip(-1.0, 1.0)
    theta = np.arccos(dot)
    s = np.sin(theta)
    small = s < 1e-6
    w0 = np.where(small, 1 - u, np.sin((1 - u) * theta) / np.where(small, 1, s))
    w1 = np.where(small, u, np.sin(u * theta) / np.where(small, 1, s))
    return quat_normalize(w0[:, None] * q0 + w1[:, None] * q1)


def resample_times(duration_s: float, fps: float) -> F64:
    """Output sample times 0, 1/fps, ... up to and including ``duration_s`` (within 1e-9)."""
    n = int(np.floor(duration_s * fps + 1e-9)) + 1
    return np.arange(n, dtype=np.float64) / fps


def _bracket(t_src: F64, t_out: F64) -> tuple[NDArray[np.int64], F64]:
    i = np.clip(np.searchsorted(t_src, t_out, side="right") - 1, 0, len(t_src) - 2)
    span = t_src[i + 1] - t_src[i]
    u = np.clip((t_out - t_src[i]) / np.where(span > 0, span, 1), 0.0, 1.0)
    return i.astype(np.int64), u


def resample_linear(t_src: F64, values: F64, t_out: F64) -> F64:
    """Linear interpolation of (T, ...) values sampled at increasing times t_src (T,)."""
    if len(t_src) < 2:
        return np.repeat(values[:1], len(t_out), axis=0)
    i, u = _bracket(t_src, t_out)
    shape = (len(t_out),) + (1,) * (values.ndim - 1)
    return values[i] * (1 - u.reshape(shape)) + values[i + 1] * u.reshape(shape)


def resample_quat(t_src: F64, quats: F64, t_out: F64) -> F64:
    """Slerp of quaternions (T, 4) sampled at times t_src (T,) onto t_out."""
    if len(t_src) < 2:
        return np.repeat(quat_normalize(quats[:1]), len(t_out), axis=0)
    i, u = _bracket(t_src, t_out)
    return slerp(quats[i], quats[i + 1], u)


def place_on_floor(joints: F64, foot_points: F64, pelvis: F64, floor_percentile: float) -> tuple[F64, float]:
    """Shift a clip (CAVE axes, +Z up) so the floor is z = 0 and its pelvis track is centred.

    joints: (T, J, 3); foot_points: (T, P, 3) the lowest points of the feet (sole corners,
    or the ankles where the source has no feet); pelvis: (T, 3). The floor is the
    ``floor_percentile`` of the per-frame lowest foot point over the clip (a low percentile,
    robust to a few frames where a retargeted foot sinks into the ground); the clip is centred
    so the pelvis's mean horizontal position is the CAVE's centre (0, 0).
    Returns the shifted joints and the floor height that was removed (metres).
    """
    lowest = np.nanmin(foot_points[..., 2], axis=1)
    floor = float(np.nanpercentile(lowest, floor_percentile))
    centre = np.nanmean(pelvis[:, :2], axis=0)
    shift = np.array([centre[0], centre[1], floor])
    return joints - shift, floor


def axis_rotations(axis: str, deg: F64) -> F64:
    """(T, 3, 3) rotations about one of x, y, z by ``deg`` (T,) degrees (right-handed)."""
    a = np.radians(np.asarray(deg, dtype=np.float64))
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    if axis == "x":
        m = [[o, z, z], [z, c, -s], [z, s, c]]
    elif axis == "y":
        m = [[c, z, s], [z, o, z], [-s, z, c]]
    else:
        m = [[c, -s, z], [s, c, z], [z, z, o]]
    return np.moveaxis(np.array(m), (0, 1), (-2, -1))
