"""Analytic two-link leg inverse kinematics with a knee direction that follows the foot."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.mathutil import fwd_vec

FloatArray = NDArray[np.float64]


def two_link_ik(
    hip: FloatArray, ankle: FloatArray, foot_yaw: FloatArray, thigh: float, shank: float
) -> tuple[FloatArray, FloatArray, int]:
    """Knee positions for hip (T,3) -> ankle (T,3) with exact segment lengths.

    The knee bends in the plane spanned by the hip-ankle line and the foot's forward
    direction.  Unreachable targets are pulled onto the reachable sphere.  Returns
    (knee, ankle_used, n_clamped).
    """
    d_vec = ankle - hip
    d = np.linalg.norm(d_vec, axis=-1)
    dmax = (thigh + shank) * (1.0 - 1e-6)
    dmin = abs(thigh - shank) + 1e-3
    clamped = (d > dmax) | (d < dmin)
    dc = np.clip(d, dmin, dmax)
    u = d_vec / np.maximum(d, 1e-9)[:, None]
    ankle_used = hip + u * dc[:, None]
    pole = np.zeros_like(hip)
    pole[:, :2] = fwd_vec(foot_yaw)
    v = pole - (pole * u).sum(-1, keepdims=True) * u
    vn = np.linalg.norm(v, axis=-1)
    bad = vn < 1e-6
    if bad.any():
        alt = np.cross(u[bad], np.array([1.0, 0.0, 0.0]))
        v[bad] = alt
        vn[bad] = np.linalg.norm(alt, axis=-1)
    v = v / vn[:, None]
    cos_a = np.clip((thigh**2 + dc**2 - shank**2) / (2.0 * thigh * dc), -1.0, 1.0)
    sin_a = np.sqrt(1.0 - cos_a**2)
    knee = hip + thigh * (cos_a[:, None] * u + sin_a[:, None] * v)
    return knee, ankle_used, int(clamped.sum())
