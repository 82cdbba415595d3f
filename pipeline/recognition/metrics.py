"""Evaluation measures of the recogniser on labelled sequences (pure functions, numpy only).

Frames are compared after smoothing (what a workstation receives). ``exclude_s`` after
every true transition is left out of the accuracy figures: the true label switches
at the onset of a motion, and any causal recogniser needs a moment to see it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import ACTIONS

_STILL = ACTIONS.index("still")


@dataclass(frozen=True, slots=True)
class Latencies:
    """Seconds from each true onset (still -> moving) to the first frame predicted moving, and from
    each true end (moving -> still) to the first frame predicted still; NaN = never within the segment.
    """

    start_s: NDArray[np.float64]
    stop_s: NDArray[np.float64]


def transition_mask(truth: NDArray[np.int64], fps: float, exclude_s: float) -> NDArray[np.bool_]:
    """True for frames at least ``exclude_s`` after the last true label change (and the first frame)."""
    t = np.asarray(truth)
    keep = np.ones(len(t), dtype=bool)
    n = round(exclude_s * fps)
    for i in np.flatnonzero(t[1:] != t[:-1]) + 1:
        keep[i : i + n] = False
    return keep


def confusion(truth: NDArray[np.int64], pred: NDArray[np.int64], k: int = len(ACTIONS)) -> NDArray[np.int64]:
    """(k, k) counts, rows = truth, columns = prediction."""
    m = np.zeros((k, k), dtype=np.int64)
    np.add.at(m, (np.asarray(truth), np.asarray(pred)), 1)
    return m


def macro_f1(conf: NDArray[np.int64]) -> float:
    """Mean over classes of 2 TP / (2 TP + FP + FN); classes absent from truth and prediction skipped."""
    tp = np.diag(conf).astype(np.float64)
    fp = conf.sum(axis=0) - tp
    fn = conf.sum(axis=1) - tp
    denom = 2 * tp + fp + fn
    present = denom > 0
    return float(np.mean(2 * tp[present] / denom[present]))


def latencies(truth: NDArray[np.int64], pred: NDArray[np.int64], fps: float) -> Latencies:
    """Start and stop latencies of one sequence (see :class:`Latencies`)."""
    t, p = np.asarray(truth), np.asarray(pred)
    moving_t, moving_p = t != _STILL, p != _STILL
    starts: list[float] = []
    stops: list[float] = []
    change = np.flatnonzero(moving_t[1:] != moving_t[:-1]) + 1
    bounds = [*change.tolist(), len(t)]
    for i, end in zip(change.tolist(), bounds[1:], strict=True):
        want = moving_t[i]
        hits = np.flatnonzero(moving_p[i:end] == want)
        lat = hits[0] / fps if hits.size else np.nan
        (starts if want else stops).append(float(lat))
    return Latencies(np.asarray(starts), np.asarray(stops))


def angle_error_deg(a: NDArray[np.floating], b: NDArray[np.floating]) -> NDArray[np.float64]:
    """Absolute smallest angle between yaw angles, degrees."""
    d = np.mod(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64) + 180.0, 360.0) - 180.0
    return np.abs(d)


def text_confusion(conf: NDArray[np.int64]) -> str:
    """The confusion matrix as an aligned text table with per-class recall."""
    w = max(8, len(str(int(conf.max()))) + 2)
    head = "truth \\ pred".ljust(14) + "".join(a.rjust(w) for a in ACTIONS) + "recall".rjust(9)
    rows = [head]
    for i, name in enumerate(ACTIONS):
        total = conf[i].sum()
        recall = conf[i, i] / total if total else float("nan")
        rows.append(name.ljust(14) + "".join(str(int(v)).rjust(w) for v in conf[i]) + f"{recall:9.3f}")
    return "\n".join(rows)


def text_histogram(
    values: NDArray[np.floating], edges: list[float], unit: str = "ms", scale: float = 1000
) -> str:
    """A text histogram of finite values (bins given in seconds, shown in ``unit``)."""
    v = np.asarray(values, dtype=np.float64)
    finite = v[np.isfinite(v)]
    counts, _ = np.histogram(finite, bins=[*edges, np.inf])
    peak = max(int(counts.max()) if counts.size else 0, 1)
    lines = []
    for lo, hi, c in zip(edges, [*edges[1:], np.inf], counts, strict=True):
        label = f"{lo * scale:5.0f}-{hi * scale:<5.0f}" if np.isfinite(hi) else f"{lo * scale:5.0f}+     "
        lines.append(f"  {label}{unit} {'#' * round(40 * c / peak):<40} {c}")
    missed = int(np.sum(~np.isfinite(v)))
    if missed:
        lines.append(f"  never detected within the segment: {missed}")
    return "\n".join(lines)
