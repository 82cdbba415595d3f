"""Small numerical helpers: easing profiles, rotations, filters."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter1d, maximum_filter1d
from scipy.signal import lfilter, lfilter_zi

FloatArray = NDArray[np.float64]

FPS: float = 30.0
GRAVITY: float = 9.81


def min_jerk(s: NDArray[np.floating] | float) -> FloatArray:
    """Minimum-jerk position profile 10s^3 - 15s^4 + 6s^5 on [0, 1] (clipped)."""
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    return s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)


def smoothstep(s: NDArray[np.floating] | float) -> FloatArray:
    """Cubic smoothstep 3s^2 - 2s^3 on [0, 1] (clipped)."""
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, 1.0)
    return s * s * (3.0 - 2.0 * s)


def bump(s: FloatArray, peak: float) -> FloatArray:
    """Asymmetric smooth bump: 0 at s=0 and s=1, 1 at s=peak, zero slope at all three."""
    s = np.asarray(s, dtype=np.float64)
    up = min_jerk(s / peak)
    down = min_jerk((1.0 - s) / (1.0 - peak))
    return np.where(s < peak, up, down)


def envelope(n: int, start: int, end: int, rise: int, fall: int | None = None) -> FloatArray:
    """Plateau envelope on frames [start, end) with smooth rise/fall inside the interval."""
    fall = rise if fall is None else fall
    t = np.arange(n, dtype=np.float64)
    up = smoothstep((t - start) / max(rise, 1))
    down = smoothstep((end - t) / max(fall, 1))
    return np.minimum(up, down)


def smooth(x: FloatArray, sigma_frames: float, axis: int = 0) -> FloatArray:
    """Gaussian smoothing along ``axis`` with edge replication."""
    if sigma_frames <= 0:
        return np.asarray(x, dtype=np.float64)
    return gaussian_filter1d(np.asarray(x, dtype=np.float64), sigma_frames, axis=axis, mode="nearest")


def conservative_smooth(x: FloatArray, width: int, sigma: float) -> FloatArray:
    """Running maximum followed by Gaussian smoothing; stays >= x when sigma << width."""
    return smooth(maximum_filter1d(np.asarray(x, dtype=np.float64), size=width, mode="nearest"), sigma)


def lipm_filter(p: FloatArray, omega: float, fps: float = FPS) -> FloatArray:
    """Bounded solution of the linear inverted pendulum  x'' = omega^2 (x - p).

    The unique non-divergent solution is the convolution of the ZMP reference ``p``
    with the kernel (omega/2) exp(-omega |t|); it equals the mean of a causal and an
    anti-causal first-order exponential filter (the anti-causal one is the capture point).
    Works along axis 0 for any trailing shape.
    """
    p = np.asarray(p, dtype=np.float64)
    a = float(np.exp(-omega / fps))
    b_coef, a_coef = [1.0 - a], [1.0, -a]
    zi = lfilter_zi(b_coef, a_coef)
    shape = (1, *p.shape[1:])
    fwd, _ = lfilter(
        b_coef, a_coef, p, axis=0, zi=zi.reshape((-1,) + (1,) * (p.ndim - 1)) * p[:1].reshape(shape)
    )
    rev = p[::-1]
    bwd, _ = lfilter(
        b_coef, a_coef, rev, axis=0, zi=zi.reshape((-1,) + (1,) * (p.ndim - 1)) * rev[:1].reshape(shape)
    )
    return 0.5 * (fwd + bwd[::-1])


def rot_x(a: FloatArray) -> FloatArray:
    """Rotation matrices about +X (body right axis); positive a tilts +Z towards -Y."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def rot_y(a: FloatArray) -> FloatArray:
    """Rotation matrices about +Y (body forward axis); positive a tilts +Z towards +X."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def rot_z(a: FloatArray) -> FloatArray:
    """Rotation matrices about +Z (yaw, counter-clockwise seen from above)."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def body_rotation(yaw: FloatArray, roll: FloatArray, pitch: FloatArray) -> FloatArray:
    """World-from-body rotation: yaw about Z, then roll about forward, then forward pitch.

    Body axes: x = right, y = forward, z = up. ``pitch`` > 0 leans the segment forward,
    ``roll`` > 0 leans it to the body's right.
    """
    return rot_z(yaw) @ rot_y(roll) @ rot_x(-np.asarray(pitch, dtype=np.float64))


def right_vec(yaw: FloatArray | float) -> FloatArray:
    """Horizontal unit vector pointing to the body's right for heading ``yaw``."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([np.cos(yaw), np.sin(yaw)], -1)


def fwd_vec(yaw: FloatArray | float) -> FloatArray:
    """Horizontal unit vector pointing forward for heading ``yaw`` (yaw=0 faces +Y)."""
    yaw = np.asarray(yaw, dtype=np.float64)
    return np.stack([-np.sin(yaw), np.cos(yaw)], -1)


def apply(rot: FloatArray, v: FloatArray) -> FloatArray:
    """Apply per-frame rotations (T,3,3) to per-frame or constant vectors (T,3)/(3,)."""
    v = np.asarray(v, dtype=np.float64)
    if v.ndim == 1:
        return rot @ v
    return np.einsum("tij,tj->ti", rot, v)


def smooth_noise(rng: np.random.Generator, n: int, sigma_frames: float, scale: float) -> FloatArray:
    """Low-frequency Gaussian noise with unit-normalised then scaled standard deviation."""
    x = smooth(rng.standard_normal(n + 8 * int(sigma_frames) + 8), sigma_frames)
    x = x[4 * int(sigma_frames) + 4 : 4 * int(sigma_frames) + 4 + n]
    sd = float(np.std(x)) or 1.0
    return x / sd * scale
