"""Rotation helpers and the closed-form leg chain (hip -> knee -> ankle).

Conventions (body / heading frame): x = right, y = forward, z = up.
Leg joint angles (left leg; the right leg is the mirror image x -> -x):
    R_thigh = Rz(rho) . Ry(alpha) . Rx(theta)
    knee  = hip + R_thigh (0, 0, -L1)
    ankle = knee + R_thigh . Rx(-kappa) (0, 0, -L2)
theta = hip flexion (knee forward), alpha = hip abduction (foot outward),
rho = hip outward rotation (toe-out), kappa = knee flexion.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

Vec3 = tuple[float, float, float]

D2R = math.pi / 180.0


def wrap(a: float) -> float:
    """The angle a wrapped into [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def leg_len(ka: float, L1: float, L2: float) -> float:
    """Hip-ankle distance for knee flexion ka."""
    return math.sqrt(L1 * L1 + L2 * L2 + 2.0 * L1 * L2 * math.cos(ka))


def leg_fk(side: int, th: float, al: float, rh: float, ka: float, L1: float, L2: float) -> tuple[Vec3, Vec3]:
    """Hip->knee and hip->ankle vectors in the heading frame. side 0 = left, 1 = right."""
    sk, ck = math.sin(ka), math.cos(ka)
    ly = -L2 * sk
    lz = -L1 - L2 * ck
    ct, st = math.cos(th), math.sin(th)
    uy = ct * ly - st * lz
    uz = st * ly + ct * lz
    ky = st * L1
    kz = -ct * L1
    ca, sa = math.cos(al), math.sin(al)
    ax, ay, az = sa * uz, uy, ca * uz
    kx, ky, kz = sa * kz, ky, ca * kz
    cr, sr = math.cos(rh), math.sin(rh)
    ax, ay = cr * ax - sr * ay, sr * ax + cr * ay
    kx, ky = cr * kx - sr * ky, sr * kx + cr * ky
    if side == 1:
        ax = -ax
        kx = -kx
    return (kx, ky, kz), (ax, ay, az)


def leg_angles_for(
    side: int, vx: float, vy: float, vz: float, rh: float, L1: float, L2: float, ka_min: float = 1.0 * D2R
) -> Vec3:
    """Closed-form (theta, alpha, kappa) of a leg whose hip->ankle vector in the heading
    frame is v, for a given hip rotation rh.  Used (a) by the planner to pose key frames of a
    grounded leg and (b) by the closed-chain correction of a second grounded foot."""
    if side == 1:
        vx = -vx
    cr, sr = math.cos(rh), math.sin(rh)
    wx = cr * vx + sr * vy
    wy = -sr * vx + cr * vy
    wz = vz
    d2 = wx * wx + wy * wy + wz * wz
    ck = (d2 - L1 * L1 - L2 * L2) / (2.0 * L1 * L2)
    ck = min(max(ck, -1.0), math.cos(ka_min))
    ka = math.acos(ck)
    ly = -L2 * math.sin(ka)
    lz = -L1 - L2 * math.cos(ka)
    uz = -math.sqrt(wx * wx + wz * wz)
    al = math.atan2(-wx, -wz)
    th = wrap(math.atan2(uz, wy) - math.atan2(lz, ly))
    return th, al, ka


# ---------------------------------------------------------------- vectorised rotations
def rot_x(a: ArrayLike) -> NDArray[np.float64]:
    """Rotations about x by the angles a: shape a.shape + (3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*a.shape, 3, 3))
    R[..., 0, 0] = 1.0
    R[..., 1, 1] = c
    R[..., 1, 2] = -s
    R[..., 2, 1] = s
    R[..., 2, 2] = c
    return R


def rot_y(a: ArrayLike) -> NDArray[np.float64]:
    """Rotations about y by the angles a: shape a.shape + (3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*a.shape, 3, 3))
    R[..., 0, 0] = c
    R[..., 0, 2] = s
    R[..., 1, 1] = 1.0
    R[..., 2, 0] = -s
    R[..., 2, 2] = c
    return R


def rot_z(a: ArrayLike) -> NDArray[np.float64]:
    """Rotations about z by the angles a: shape a.shape + (3, 3)."""
    a = np.asarray(a, dtype=float)
    c, s = np.cos(a), np.sin(a)
    R = np.zeros((*a.shape, 3, 3))
    R[..., 0, 0] = c
    R[..., 0, 1] = -s
    R[..., 1, 0] = s
    R[..., 1, 1] = c
    R[..., 2, 2] = 1.0
    return R


def mv(R: NDArray[np.float64], v: ArrayLike) -> NDArray[np.float64]:
    """Apply (T,3,3) rotations to a constant (3,) or per-frame (T,3) vector."""
    v = np.asarray(v, dtype=float)
    if v.ndim == 1:
        return R @ v
    return np.einsum("tij,tj->ti", R, v)
