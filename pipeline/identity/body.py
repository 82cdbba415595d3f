"""Body measurements that stay the same whatever a person does: bone lengths and stature.

A skeleton gives, per frame, the :data:`MEASURES` (metres; NaN where a joint is unknown): the
shoulder and hip breadths, the trunk, upper arm, forearm, thigh and shin (left and right
averaged), the neck (shoulder centre to ear centre) and the stature they add up to (shin +
thigh + trunk + neck: the ear height of the person standing straight, whatever their posture).
A person's signature is the median over many frames; two signatures are compared by the RMS of
their differences over the measures both have.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import J

F64 = NDArray[np.float64]
B = NDArray[np.bool_]

MEASURES: tuple[str, ...] = (
    "shoulders",
    "hips",
    "trunk",
    "upper_arm",
    "forearm",
    "thigh",
    "shin",
    "neck",
    "stature",
)
_PAIRS = {
    "shoulders": [("l_shoulder", "r_shoulder")],
    "hips": [("l_hip", "r_hip")],
    "trunk": [("l_shoulder", "l_hip"), ("r_shoulder", "r_hip")],
    "upper_arm": [("l_shoulder", "l_elbow"), ("r_shoulder", "r_elbow")],
    "forearm": [("l_elbow", "l_wrist"), ("r_elbow", "r_wrist")],
    "thigh": [("l_hip", "l_knee"), ("r_hip", "r_knee")],
    "shin": [("l_knee", "l_ankle"), ("r_knee", "r_ankle")],
}
MIN_COMMON = 4  # measures two signatures must share to be compared


_A = np.array([J[a] for name in MEASURES[:7] for a, _ in _PAIRS[name]])
_B = np.array([J[b] for name in MEASURES[:7] for _, b in _PAIRS[name]])
_FEATURE = np.array([k for k, name in enumerate(MEASURES[:7]) for _ in _PAIRS[name]])
_SHOULDERS = [J["l_shoulder"], J["r_shoulder"]]
_EARS = [J["l_ear"], J["r_ear"]]


def body_measures(joints_m: F64, valid: B | None = None) -> F64:
    """(17, 3) joints -> (len(MEASURES),) metres, NaN where unknown."""
    j = np.asarray(joints_m, dtype=np.float64)
    if valid is not None:
        j = np.where(np.asarray(valid, dtype=bool)[:, None], j, np.nan)
    d = np.linalg.norm(j[_A] - j[_B], axis=1)  # every (left and right) bone
    ok = np.isfinite(d)
    total = np.bincount(_FEATURE, np.where(ok, d, 0.0), minlength=7)
    count = np.bincount(_FEATURE, ok.astype(np.float64), minlength=7)
    out = np.full(len(MEASURES), np.nan)
    out[:7] = np.where(count > 0, total / np.maximum(count, 1.0), np.nan)  # left and right averaged
    out[7] = np.linalg.norm(j[_EARS].mean(axis=0) - j[_SHOULDERS].mean(axis=0))
    out[8] = out[6] + out[5] + out[2] + out[7]
    return out


def signature(samples: F64) -> F64:
    """(N, len(MEASURES)) per-frame measures -> their median per measure (NaN where none)."""
    s = np.asarray(samples, dtype=np.float64).reshape(-1, len(MEASURES))
    out = np.full(len(MEASURES), np.nan)
    for k in range(len(MEASURES)):
        col = s[:, k]
        col = col[np.isfinite(col)]
        if col.size:
            out[k] = float(np.median(col))
    return out


def measure_distance(a: F64, b: F64) -> float:
    """RMS difference (metres) of two signatures over the measures both have; inf with fewer
    than :data:`MIN_COMMON` in common."""
    both = np.isfinite(a) & np.isfinite(b)
    if int(both.sum()) < MIN_COMMON:
        return float("inf")
    return float(np.sqrt(np.mean((a[both] - b[both]) ** 2)))
