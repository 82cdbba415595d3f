"""The clock and the smooth time profiles of the blind2 motion model.

The frame clock (30 fps, :func:`frames`), the 0→1 minimum-jerk ramp and the 0→1→0 sin² bump that
shape a foot's swing, the raised-cosine envelope that blends a behaviour in and out, smoothed
piecewise-linear curves and smoothed random noise. Pure functions of their arguments (the noise of
its generator).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import gaussian_filter1d

FPS = 30.0  # frames per second of every sequence
DEG = math.pi / 180.0  # radians per degree


def frames(seconds: float) -> int:
    """The whole number of frames nearest to ``seconds`` (at least 1)."""
    return max(1, round(float(seconds * FPS)))


def min_jerk(t: ArrayLike) -> NDArray[np.float64]:
    """Minimum-jerk ramp 0→1 over t in [0, 1] (clipped outside)."""
    t = np.clip(t, 0.0, 1.0)
    return np.asarray(t * t * t * (10.0 - 15.0 * t + 6.0 * t * t), dtype=np.float64)


def bump(t: ArrayLike) -> NDArray[np.float64]:
    """Smooth bump 0→1→0 over t in [0, 1] (sin²), with zero slope at both ends."""
    t = np.clip(t, 0.0, 1.0)
    return np.asarray(np.sin(np.pi * t) ** 2, dtype=np.float64)


def envelope(n: int, ramp_in: int, ramp_out: int) -> NDArray[np.float64]:
    """(n,) weights: a raised-cosine ramp 0→1 over ``ramp_in`` frames, 1, then 1→0 over ``ramp_out``."""
    w = np.ones(n)
    rin = int(min(max(ramp_in, 0), n // 2))
    rout = int(min(max(ramp_out, 0), n - rin))
    if rin > 0:
        w[:rin] = 0.5 - 0.5 * np.cos(np.pi * (np.arange(rin) + 0.5) / rin)
    if rout > 0:
        w[n - rout :] = 0.5 + 0.5 * np.cos(np.pi * (np.arange(rout) + 0.5) / rout)
    return w


def piecewise_smooth(n: int, knots: Sequence[tuple[float, float]], sigma: float) -> NDArray[np.float64]:
    """(n,) piecewise-linear curve through (frame, value) knots, Gaussian-smoothed by sigma frames."""
    xs = np.array([k[0] for k in knots], float)
    ys = np.array([k[1] for k in knots], float)
    y = np.interp(np.arange(n), xs, ys)
    if sigma > 0:
        y = gaussian_filter1d(y, sigma, mode="nearest")
    return np.asarray(y, dtype=np.float64)


def smooth_noise(rng: np.random.Generator, n: int, sigma_frames: float, amp: float) -> NDArray[np.float64]:
    """(n,) zero-mean noise, Gaussian-smoothed by sigma_frames (circularly), scaled to sd ``amp``."""
    x = gaussian_filter1d(rng.normal(size=n), sigma_frames, mode="wrap")
    s = x.std()
    return np.asarray(x / s * amp if s > 0 else x, dtype=np.float64)
