"""Body measurements that stay the same whatever a person does: bone lengths and stature.

A skeleton gives, per frame, the :data:`MEASURES` (metres; NaN where a joint is unknown): the
shoulder and hip breadths, the trunk, upper arm, forearm, thigh and shin (left and right
averaged), the neck (shoulder centre to ear centre) and the stature they add up to (shin +
thigh + trunk + neck: the ear height of the person standing straight, whatever their posture).
A person's signature is the median over many frames; two signatures are compared by the RMS of
their differences over the measures both have.
"""

from __future__ import annotations

import warnings

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


def body_measures(joints_m: F64, valid: B | None = None) -> F64:
    """(17, 3) joints -> (len(MEASURES),) metres, NaN where unknown."""
    j = np.asarray(joints_m, dtype=np.float64).copy()
    if valid is not None:
        j[~np.asarray(valid, dtype=bool)] = np.nan
    out = np.full(len(MEASURES), np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN means
        for k, name in enumerate(MEASURES[:7]):
            d = [np.linalg.norm(j[J[a]] - j[J[b]]) for a, b in _PAIRS[name]]
            out[k] = np.nanmean(d)
        neck = np.linalg.norm(
            0.5 * (j[J["l_ear"]] + j[J["r_ear"]]) - 0.5 * (j[J["l_shoulder"]] + j[J["r_shoulder"]])
        )
        out[7] = neck
    out[8] = out[6] + out[5] + out[2] + out[7]
    return out


def signature(samples: F64) -> F64:
    """(N, len(MEASURES)) per-frame measures -> their median (NaN where none)."""
    s = np.asarray(samples, dtype=np.float64).reshape(-1, len(MEASURES))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        med: F64 = np.nanmedian(s, axis=0) if len(s) else np.full(len(MEASURES), np.nan)
    return med


def measure_distance(a: F64, b: F64) -> float:
    """RMS difference (metres) of two signatures over the measures both have; inf with fewer
    than :data:`MIN_COMMON` in common."""
    both = np.isfinite(a) & np.isfinite(b)
    if int(both.sum()) < MIN_COMMON:
        return float("inf")
    return float(np.sqrt(np.mean((a[both] - b[both]) ** 2)))
