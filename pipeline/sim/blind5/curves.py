"""Eased keyframe curves (cubic Hermite) and slow smooth random drift."""

import numpy as np


def smoothstep(u):
    u = np.clip(u, 0.0, 1.0)
    return u * u * (3.0 - 2.0 * u)


def _prep(kt, kv):
    kt = np.asarray(kt, dtype=float)
    kv = np.asarray(kv, dtype=float)
    vec = kv.ndim > 1
    if not vec:
        kv = kv[:, None]
    return kt, kv, vec


def _segment(t, kt):
    i = np.clip(np.searchsorted(kt, t, side="right") - 1, 0, len(kt) - 2)
    h = np.maximum(kt[i + 1] - kt[i], 1e-12)
    u = np.clip((t - kt[i]) / h, 0.0, 1.0)
    return i, h, u


def ease_keys(t, kt, kv):
    """Hermite with flat tangents (animator ease-in/ease-out between every pair of keys).

    Never overshoots: a value stays between its two neighbouring keys, and holds
    outside the key range, so equal consecutive keys give an exact hold."""
    kt, kv, vec = _prep(kt, kv)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if len(kt) == 1:
        out = np.repeat(kv, len(t), 0)
    else:
        i, _, u = _segment(t, kt)
        out = kv[i] + (kv[i + 1] - kv[i]) * smoothstep(u)[:, None]
    return out if vec else out[:, 0]


def spline(t, kt, kv, tension=0.0):
    """Cardinal cubic Hermite spline: Catmull-Rom tangents scaled by (1 - tension);
    tension 1 gives pure ease-in/out. Flat tangents at the end keys."""
    kt, kv, vec = _prep(kt, kv)
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if len(kt) == 1:
        out = np.repeat(kv, len(t), 0)
        return out if vec else out[:, 0]
    m = np.zeros_like(kv)
    if len(kt) > 2:
        m[1:-1] = (1.0 - tension) * (kv[2:] - kv[:-2]) / (kt[2:] - kt[:-2])[:, None]
    i, h, u = _segment(t, kt)
    u = u[:, None]
    h = h[:, None]
    u2, u3 = u * u, u * u * u
    out = (
        (2 * u3 - 3 * u2 + 1) * kv[i]
        + (u3 - 2 * u2 + u) * h * m[i]
        + (-2 * u3 + 3 * u2) * kv[i + 1]
        + (u3 - u2) * h * m[i + 1]
    )
    return out if vec else out[:, 0]


def drift(rng, n, fps, amp, gap=(1.5, 4.0)):
    """Slow smooth random drift: random keys every gap seconds, Catmull-Rom through them."""
    times = [-rng.uniform(0.0, gap[1])]
    while times[-1] < n / fps + gap[1]:
        times.append(times[-1] + rng.uniform(*gap))
    kt = np.array(times) * fps
    kv = rng.uniform(-amp, amp, size=len(kt))
    return spline(np.arange(n, dtype=float), kt, kv, 0.0)
