"""Small pure signal helpers of the simulator (vectorised over frames; times in seconds)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import gaussian_filter1d

F64 = NDArray[np.float64]


def smoothstep(x: F64) -> F64:
    """0 below 0, 1 above 1, a smooth S in between (zero slope at both ends)."""
    c = np.clip(x, 0.0, 1.0)
    return c * c * (3.0 - 2.0 * c)


def bump(s: F64) -> F64:
    """sin^2(pi s) on (0, 1), 0 elsewhere: a lift that starts and lands softly."""
    return np.where((s > 0.0) & (s < 1.0), np.sin(np.pi * np.clip(s, 0.0, 1.0)) ** 2, 0.0)


def window(t: F64, t0: float, t1: float, ramp_in_s: float, ramp_out_s: float | None = None) -> F64:
    """1 inside [t0, t1], smooth ramps of ``ramp_in_s`` after t0 and ``ramp_out_s`` before t1."""
    r_in = max(ramp_in_s, 1e-6)
    r_out = max(ramp_in_s if ramp_out_s is None else ramp_out_s, 1e-6)
    return smoothstep((t - t0) / r_in) * smoothstep((t1 - t) / r_out)


def noise(rng: np.random.Generator, t: F64, f_lo: float, f_hi: float, n: int = 3) -> F64:
    """Smooth random signal in [-1, 1]: a few sinusoids of random frequency and phase."""
    f = rng.uniform(f_lo, f_hi, n)
    ph = rng.uniform(0, 2 * np.pi, n)
    a = rng.uniform(0.5, 1.0, n)
    out: F64 = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t[None, :] + ph[:, None])).sum(0) / a.sum()
    return out


def smooth(x: F64, sigma_frames: F64 | float) -> F64:
    """Gaussian smoothing along axis 0 with a per-frame sigma (frames); edges held.

    ``x`` is (T, ...). Non-causal: a body anticipates what its feet will do. A per-frame sigma
    takes, at each frame, the signal smoothed with that frame's sigma (sigmas rounded to a
    quarter frame; a routine has only a few).
    """
    arr = np.asarray(x, dtype=np.float64)
    n = arr.shape[0]
    sig = np.round(np.broadcast_to(np.asarray(sigma_frames, dtype=np.float64), (n,)) * 4.0) / 4.0
    out = arr.copy()
    for value in np.unique(sig).tolist():
        if value < 0.3:
            continue
        use = sig == value
        out[use] = gaussian_filter1d(arr, value, axis=0, mode="nearest", truncate=3.0)[use]
    return out


def wrap_deg(a: F64) -> F64:
    """Angles to (-180, 180]."""
    return 180.0 - np.mod(180.0 - np.asarray(a, dtype=np.float64), 360.0)
