"""Rotations, facing vectors and the two-link inverse kinematics of the blind2 body.

The CAVE frame is right-handed with +Z up; a yaw of 0 faces +Y and a positive yaw turns
counter-clockwise seen from above, so the facing vector is (−sin ψ, cos ψ) and the person's right
is (cos ψ, sin ψ). Pure functions.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]


def rot_z(a: ArrayLike) -> F64:
    """(..., 3, 3) rotations by angle(s) ``a`` (rad) about +Z."""
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def rot_x(a: ArrayLike) -> F64:
    """(..., 3, 3) rotations by angle(s) ``a`` (rad) about +X."""
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(a: ArrayLike) -> F64:
    """(..., 3, 3) rotations by angle(s) ``a`` (rad) about +Y."""
    a = np.asarray(a, float)
    c, s = np.cos(a), np.sin(a)
    z, o = np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def apply(rot: F64, v: ArrayLike) -> F64:
    """Rotations (T, 3, 3) applied to one vector (3,) or to one vector per frame (T, 3): (T, 3)."""
    v = np.asarray(v, float)
    if v.ndim == 1:
        return np.asarray(np.einsum("tij,j->ti", rot, v), dtype=np.float64)
    return np.asarray(np.einsum("tij,tj->ti", rot, v), dtype=np.float64)


def facing_vec(yaw: float) -> F64:
    """(2,) horizontal unit vector a person with this yaw (rad) faces."""
    return np.array([-math.sin(yaw), math.cos(yaw)])


def right_vec(yaw: float) -> F64:
    """(2,) horizontal unit vector to the right of a person with this yaw (rad)."""
    return np.array([math.cos(yaw), math.sin(yaw)])


def two_link_ik(root: F64, target: F64, l1: float, l2: float, pole: F64) -> tuple[F64, F64, F64]:
    """Analytic two-link IK, per frame: (mid joint (T, 3), end point (T, 3), residual (T,) m).

    root, target, pole: (T, 3). The mid joint bends toward ``pole``; an out-of-reach target is
    clipped to 99.95 % of the reach, and the residual is how far the end point falls short of it.
    """
    v = target - root
    d = np.linalg.norm(v, axis=-1)
    dc = np.clip(d, abs(l1 - l2) + 1e-4, (l1 + l2) * 0.9995)
    n = v / np.maximum(d, 1e-9)[:, None]
    a = (l1 * l1 - l2 * l2 + dc * dc) / (2 * dc)
    h = np.sqrt(np.maximum(l1 * l1 - a * a, 0.0))
    p = pole - np.sum(pole * n, -1, keepdims=True) * n
    p /= np.maximum(np.linalg.norm(p, axis=-1, keepdims=True), 1e-9)
    mid = root + n * a[:, None] + p * h[:, None]
    end = root + n * dc[:, None]
    return mid, end, d - dc
