"""Timing laws and signal shaping for the blind generator: how a value travels from 0 to 1.

Pure functions over numpy arrays. A *law* maps normalised time x in [0, 1] to progress in [0, 1]:

- ``minjerk``: the minimum-jerk polynomial 10x³ − 15x⁴ + 6x⁵ (Flash & Hogan), zero velocity and
  acceleration at both ends;
- ``cosine``: the raised cosine ½ − ½·cos(πx), zero velocity at both ends;
- ``quick``: 1 − (1 − x)^2.5, a fast start that settles gently (an eager, front-loaded movement).
"""

from __future__ import annotations

from itertools import pairwise

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

LAWS: tuple[str, ...] = ("minjerk", "cosine", "quick")

FloatArray = NDArray[np.float64]


def progress(law: str, x: FloatArray | float) -> FloatArray:
    """Progress in [0, 1] of ``law`` at normalised time ``x`` (clipped to [0, 1])."""
    u = np.clip(np.asarray(x, dtype=np.float64), 0.0, 1.0)
    if law == "minjerk":
        return np.asarray(u**3 * (10.0 - 15.0 * u + 6.0 * u * u), dtype=np.float64)
    if law == "cosine":
        return np.asarray(0.5 - 0.5 * np.cos(np.pi * u), dtype=np.float64)
    if law == "quick":
        return np.asarray(1.0 - (1.0 - u) ** 2.5, dtype=np.float64)
    raise InputError(f"unknown timing law {law!r}; expected one of {list(LAWS)}")


def swing_height(law: str, tau: FloatArray, peak_frac: float, hold_frac: float) -> FloatArray:
    """Normalised foot height (0 on the floor, 1 at the top) over a swing's normalised time ``tau``.

    The foot rises over [0, peak_frac], stays at the top for ``hold_frac`` (a marcher who pauses with
    the knee up) and comes down over the rest; rise and fall both follow ``law`` (the fall mirrored,
    so a ``quick`` swing leaves and lands briskly).
    """
    t = np.clip(np.asarray(tau, dtype=np.float64), 0.0, 1.0)
    top_end = peak_frac + hold_frac
    rise = progress(law, t / peak_frac)
    fall = progress(law, (1.0 - t) / (1.0 - top_end))
    return np.where(t < peak_frac, rise, np.where(t <= top_end, 1.0, fall))


def keyframes(t_s: FloatArray, keys: list[tuple[float, float]], law: str = "cosine") -> FloatArray:
    """A curve through ``keys`` ((time s, value), increasing times), sampled at ``t_s``.

    Between two keys the value moves by ``law``; before the first key it holds the first value and
    after the last key the last value.
    """
    if not keys:
        raise InputError("keyframes need at least one (time, value) key")
    times = [k[0] for k in keys]
    if any(b < a for a, b in pairwise(times)):
        raise InputError(f"keyframe times must not decrease, got {times}")
    out = np.full(t_s.shape, keys[0][1], dtype=np.float64)
    for (t0, v0), (t1, v1) in pairwise(keys):
        if t1 <= t0:
            out[t_s >= t1] = v1
            continue
        inside = (t_s >= t0) & (t_s <= t1)
        out[inside] = v0 + (v1 - v0) * progress(law, (t_s[inside] - t0) / (t1 - t0))
        out[t_s > t1] = v1
    return out


def gaussian_smooth(x: FloatArray, sigma_frames: float) -> FloatArray:
    """Zero-phase Gaussian smoothing along axis 0 (edges reflected); sigma in frames."""
    a = np.asarray(x, dtype=np.float64)
    if sigma_frames <= 0.0 or a.shape[0] < 2:
        return a.copy()
    half = max(1, int(np.ceil(3.0 * sigma_frames)))
    half = min(half, a.shape[0] - 1)
    k = np.exp(-0.5 * (np.arange(-half, half + 1) / sigma_frames) ** 2)
    k /= k.sum()
    pad = [(half, half)] + [(0, 0)] * (a.ndim - 1)
    padded = np.pad(a, pad, mode="reflect")
    windows = np.lib.stride_tricks.sliding_window_view(padded, k.size, axis=0)
    return np.asarray(windows @ k, dtype=np.float64)


def smooth_noise(
    rng: np.random.Generator, n: int, sigma_frames: float, std: float, dims: int = 1
) -> FloatArray:
    """Band-limited random wander (n, dims) with standard deviation ``std`` per dimension."""
    white = rng.normal(0.0, 1.0, size=(n, dims))
    s = gaussian_smooth(white, sigma_frames)
    spread = s.std(axis=0)
    spread[spread == 0.0] = 1.0
    return np.asarray((s - s.mean(axis=0)) / spread * std, dtype=np.float64)


def soft_min(values: list[FloatArray], k: float) -> FloatArray:
    """A smooth minimum, never above the true minimum: −k·log Σ exp(−v/k)."""
    stack = np.stack([np.asarray(v, dtype=np.float64) for v in values])
    m = stack.min(axis=0)
    return np.asarray(m - k * np.log(np.exp(-(stack - m) / k).sum(axis=0)), dtype=np.float64)


def wrap_deg(a: FloatArray | float) -> FloatArray:
    """Angles wrapped to [−180, 180) degrees."""
    return np.asarray((np.asarray(a, dtype=np.float64) + 180.0) % 360.0 - 180.0, dtype=np.float64)
