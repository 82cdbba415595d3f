"""Evaluation measures of the recogniser on labelled sequences (pure functions, numpy only).

Frames are compared after smoothing (what a workstation receives). ``exclude_s`` after
every true transition is left out of the accuracy figures: the true label switches
at the onset of a motion, and any causal recogniser needs a moment to see it.
"""

from __future__ import annotations

import itertools
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


# ---------------------------------------------------------------- the evaluation report
# One report for `cavewalk evaluate`, scripts/eval_action.py and the model card's tables.

MOVING_LABELS = tuple(a for a in ACTIONS if a != "still")
UNTAGGED = "(untagged)"


@dataclass(frozen=True, slots=True)
class ScoredSequence:
    """Truth and prediction of one sequence.

    truth: (T,) class indices, -1 = ignore (left out of every frame figure).
    pred: (T,) predicted class indices (what a workstation receives).
    tags: (T,) behaviour names ("" = none). contacts: (T, 2) ground-truth foot contact or None.
    """

    name: str
    source: str
    truth: NDArray[np.int64]
    pred: NDArray[np.int64]
    tags: NDArray[np.str_]
    fps: float
    contacts: NDArray[np.bool_] | None = None

    def __post_init__(self) -> None:
        n = len(self.truth)
        if np.shape(self.pred) != (n,) or np.shape(self.tags) != (n,):
            raise ValueError(
                f"truth {np.shape(self.truth)}, pred {np.shape(self.pred)} and tags {np.shape(self.tags)} "
                "must be (T,) alike"
            )
        if self.contacts is not None and np.shape(self.contacts) != (n, 2):
            raise ValueError(f"contacts must be ({n}, 2), got {np.shape(self.contacts)}")
        if not np.isfinite(self.fps) or self.fps <= 0:
            raise ValueError(f"fps must be positive, got {self.fps}")


@dataclass(frozen=True, slots=True)
class LatencyStats:
    """Latencies in seconds; a transition never detected within its segment is ``missed`` and counts
    as infinitely late in the median and p95 (so these are None when too many are missed)."""

    values_s: tuple[float, ...]
    missed: int

    @property
    def n(self) -> int:
        return len(self.values_s) + self.missed

    def quantile(self, q: float) -> float | None:
        if self.n == 0:
            return None
        v = np.array([*self.values_s, *([np.inf] * self.missed)])
        out = float(np.percentile(v, q, method="inverted_cdf"))
        return out if np.isfinite(out) else None

    @property
    def median_s(self) -> float | None:
        return self.quantile(50)

    @property
    def p95_s(self) -> float | None:
        return self.quantile(95)

    def to_dict(self) -> dict[str, object]:
        return {
            "n": self.n,
            "median_s": self.median_s,
            "p95_s": self.p95_s,
            "missed": self.missed,
            "values_s": [round(v, 4) for v in self.values_s],
        }


@dataclass(frozen=True, slots=True)
class GroupStats:
    """Frame counts of one tag or one sequence (after the exclusions of the accuracy figures).

    still_frames / false_moving: truly still frames and those predicted moving;
    false_after / false_without: of those, the frames of a predicted bout that met a true bout before
    them (the command held on past the bout's end) and of a predicted bout that meets none (a false
    start: movement nobody stepped for); the rest are a predicted bout that began before its true
    one (see :func:`false_movement_kinds`);
    moving_frames / detected_moving: truly moving frames and those predicted as any movement;
    correct: frames predicted with the exact true class;
    planted_still / planted_false: the truly still frames in which the file's contacts have both
    feet on the floor, and those predicted moving (the issue's "no movement while both feet stay
    planted"); contact_frames: frames whose contacts the file gives (0: none, the figure is None).
    """

    name: str
    frames: int
    correct: int
    still_frames: int
    false_moving: int
    moving_frames: int
    detected_moving: int
    false_after: int
    false_without: int
    planted_still: int = 0
    planted_false: int = 0
    contact_frames: int = 0

    @property
    def accuracy(self) -> float | None:
        return self.correct / self.frames if self.frames else None

    @property
    def still_planted(self) -> int | None:
        """The truly still frames with both feet planted (the files' contacts); None without contacts."""
        return self.planted_still if self.contact_frames else None

    @property
    def false_movement_planted(self) -> float | None:
        """Share of the truly still frames with both feet planted (the files' contacts) that were
        predicted moving; None without contacts or without such frames."""
        return self.planted_false / self.planted_still if self.still_planted else None

    def _of_still(self, n: int) -> float | None:
        return n / self.still_frames if self.still_frames else None

    @property
    def false_movement(self) -> float | None:
        return self._of_still(self.false_moving)

    @property
    def false_after_bout(self) -> float | None:
        """Share of the truly still frames held moving after a true bout (the hold, a late stop)."""
        return self._of_still(self.false_after)

    @property
    def false_starts(self) -> float | None:
        """Share of the truly still frames in a predicted bout that meets no true bout."""
        return self._of_still(self.false_without)

    @property
    def false_before_bout(self) -> float | None:
        """Share of the truly still frames in a predicted bout that began before its true one."""
        return self._of_still(self.false_moving - self.false_after - self.false_without)

    @property
    def movement_detected(self) -> float | None:
        return self.detected_moving / self.moving_frames if self.moving_frames else None

    def to_dict(self) -> dict[str, object]:
        return {
            "name": self.name,
            "frames": self.frames,
            "accuracy": self.accuracy,
            "still_frames": self.still_frames,
            "false_movement": self.false_movement,
            "false_movement_after_bout": self.false_after_bout,
            "false_movement_before_bout": self.false_before_bout,
            "false_starts": self.false_starts,
            "false_movement_both_feet_planted": self.false_movement_planted,
            "still_frames_both_feet_planted": self.still_planted,
            "moving_frames": self.moving_frames,
            "movement_detected": self.movement_detected,
        }


@dataclass(frozen=True, slots=True)
class Evaluation:
    """Everything `cavewalk evaluate` reports (see :func:`evaluate`)."""

    confusion: NDArray[np.int64]  # (4, 4) rows = truth, columns = prediction
    start: LatencyStats
    stop: LatencyStats
    stop_beyond_rhythm: LatencyStats
    overall: GroupStats
    per_tag: tuple[GroupStats, ...]
    per_sequence: tuple[GroupStats, ...]
    per_source: tuple[GroupStats, ...]
    true_changes: int
    predicted_changes: int
    exclude_s: float

    @property
    def frames(self) -> int:
        return int(self.confusion.sum())

    @property
    def accuracy(self) -> float | None:
        return float(np.trace(self.confusion) / self.frames) if self.frames else None

    @property
    def macro_f1(self) -> float | None:
        return macro_f1(self.confusion) if self.frames else None

    def per_class(self) -> dict[str, dict[str, float | int | None]]:
        out: dict[str, dict[str, float | int | None]] = {}
        for i, name in enumerate(ACTIONS):
            tp = int(self.confusion[i, i])
            support, predicted = int(self.confusion[i].sum()), int(self.confusion[:, i].sum())
            p = tp / predicted if predicted else None
            r = tp / support if support else None
            f1 = 2 * tp / (support + predicted) if support + predicted else None
            out[name] = {"precision": p, "recall": r, "f1": f1, "support": support, "predicted": predicted}
        return out

    @property
    def flicker(self) -> float | None:
        """Command changes per true change (1.0 = no flicker)."""
        return self.predicted_changes / self.true_changes if self.true_changes else None

    def to_dict(self) -> dict[str, object]:
        return {
            "frames": self.frames,
            "accuracy": self.accuracy,
            "macro_f1": self.macro_f1,
            "classes": list(ACTIONS),
            "per_class": self.per_class(),
            "confusion": self.confusion.tolist(),
            "start_latency": self.start.to_dict(),
            "stop_latency": self.stop.to_dict(),
            "stop_latency_beyond_rhythm": self.stop_beyond_rhythm.to_dict(),
            "false_movement": self.overall.false_movement,
            "false_movement_after_bout": self.overall.false_after_bout,
            "false_movement_before_bout": self.overall.false_before_bout,
            "false_starts": self.overall.false_starts,
            "false_movement_both_feet_planted": self.overall.false_movement_planted,
            "still_frames_both_feet_planted": self.overall.still_planted,
            "still_frames": self.overall.still_frames,
            "movement_detected": self.overall.movement_detected,
            "moving_frames": self.overall.moving_frames,
            "command_changes_per_true_change": self.flicker,
            "exclude_s": self.exclude_s,
            "per_tag": [g.to_dict() for g in self.per_tag],
            "per_source": [g.to_dict() for g in self.per_source],
            "per_sequence": [g.to_dict() for g in self.per_sequence],
        }


def fill_ignore(truth: NDArray[np.int64]) -> NDArray[np.int64]:
    """``ignore`` frames (-1) take the previous label (the next one at the start; still if all ignore)."""
    t = np.asarray(truth, dtype=np.int64).copy()
    known = np.flatnonzero(t >= 0)
    if known.size == 0:
        return np.full_like(t, _STILL)
    idx = np.maximum.accumulate(np.where(t >= 0, np.arange(len(t)), -1))
    idx[idx < 0] = known[0]
    return t[idx]


def rhythm_pauses_s(moving: NDArray[np.bool_], contacts: NDArray[np.bool_] | None, fps: float) -> list[float]:
    """For each true bout (run of moving frames), the typical pause its own rhythm allows: the median
    of the both-feet-down intervals inside it (from ground-truth ``contacts``); 0 without contacts."""
    m = np.asarray(moving, dtype=bool)
    change = np.flatnonzero(m[1:] != m[:-1]) + 1
    bounds = [0, *change.tolist(), len(m)]
    out: list[float] = []
    for a, b in itertools.pairwise(bounds):
        if not m[a]:
            continue
        if contacts is None:
            out.append(0.0)
            continue
        both: NDArray[np.bool_] = np.asarray(np.asarray(contacts[a:b], dtype=bool).all(axis=1))
        ch = np.flatnonzero(both[1:] != both[:-1]) + 1
        edges = [0, *ch.tolist(), len(both)]
        runs = [
            (e1 - e0) / fps for e0, e1 in itertools.pairwise(edges) if both[e0] and e0 > 0 and e1 < len(both)
        ]  # interior runs only
        out.append(float(np.median(runs)) if runs else 0.0)
    return out


AFTER_BOUT, BEFORE_BOUT, NO_BOUT = 1, 2, 3  # see false_movement_kinds


def false_movement_kinds(truth: NDArray[np.int64], pred: NDArray[np.int64]) -> NDArray[np.int8]:
    """Why each truly still frame predicted moving is so (0 for every other frame), by the predicted
    bout (run of moving frames) it lies in: ``AFTER_BOUT`` the run met a true bout before this frame
    (the command held on past that bout's end: the pause the person's rhythm allows, or a late stop);
    ``BEFORE_BOUT`` it meets a true bout only later (it began before the labelled onset);
    ``NO_BOUT`` it meets no true bout at all (a false start). ``truth`` without ``ignore`` frames
    (:func:`fill_ignore`)."""
    t, p = np.asarray(truth), np.asarray(pred)
    if t.shape != p.shape:
        raise ValueError(f"truth {t.shape} and pred {p.shape} must be alike")
    out = np.zeros(t.shape, dtype=np.int8)
    moving_p, moving_t = p != _STILL, t != _STILL
    change = np.flatnonzero(moving_p[1:] != moving_p[:-1]) + 1
    for a, b in itertools.pairwise([0, *change.tolist(), len(p)]):
        if not moving_p[a]:
            continue
        met = np.flatnonzero(moving_t[a:b])
        run = out[a:b]  # a view: written through
        if met.size == 0:
            run[:] = NO_BOUT
            continue
        still = ~moving_t[a:b]
        at = np.arange(b - a)
        run[still & (at < met[0])] = BEFORE_BOUT
        run[still & (at > met[0])] = AFTER_BOUT
    return out


def _group(
    name: str, truth: NDArray[np.int64], pred: NDArray[np.int64], kinds: NDArray[np.int8],
    planted: NDArray[np.int8],
) -> GroupStats:
    """One group's counts; ``planted``: 1 both feet planted, 0 not, -1 the file gives no contacts."""
    still = truth == _STILL
    moving = truth > _STILL
    both = still & (planted == 1)
    return GroupStats(
        name=name,
        frames=int(truth.size),
        correct=int(np.sum(truth == pred)),
        still_frames=int(still.sum()),
        false_moving=int(np.sum(still & (pred != _STILL))),
        moving_frames=int(moving.sum()),
        detected_moving=int(np.sum(moving & (pred != _STILL))),
        false_after=int(np.sum(kinds == AFTER_BOUT)),
        false_without=int(np.sum(kinds == NO_BOUT)),
        planted_still=int(both.sum()),
        planted_false=int(np.sum(both & (pred != _STILL))),
        contact_frames=int(np.sum(planted >= 0)),
    )


def evaluate(sequences: list[ScoredSequence], exclude_s: float = 0.3) -> Evaluation:
    """Score predictions against labels over many sequences.

    Frame figures (confusion, accuracy, per-class precision/recall, false movement and movement
    detected per tag / sequence / source) leave out ``ignore`` frames and the ``exclude_s`` after
    each true label change. Start latency: from each true still -> moving onset (the first lift-off)
    to the first frame predicted moving within that bout; stop latency: from each true end (the
    last touch-down) to the first frame predicted still within the following still stretch;
    ``stop_beyond_rhythm``: the stop latency minus the bout's own typical pause between steps
    (from ground-truth contacts when the file has them, else nothing is subtracted). False movement
    is also split by the predicted bout it lies in (:func:`false_movement_kinds`): held on after a
    true bout, or a false start (a predicted bout that meets no true one); and counted over the
    still frames in which the file's contacts have both feet planted (files without contacts give
    no such figure).
    """
    if exclude_s < 0:
        raise ValueError(f"exclude_s must be >= 0, got {exclude_s}")
    conf = np.zeros((len(ACTIONS), len(ACTIONS)), dtype=np.int64)
    starts: list[float] = []
    stops: list[float] = []
    beyond: list[float] = []
    n_start_missed = n_stop_missed = 0
    # truth, pred, false kinds, both feet planted (1 / 0, -1: no contacts in the file)
    Part = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int8], NDArray[np.int8]]
    by_tag: dict[str, list[Part]] = {}
    per_seq: list[GroupStats] = []
    by_src: dict[str, list[Part]] = {}
    true_changes = pred_changes = 0
    for s in sequences:
        truth = np.asarray(s.truth, dtype=np.int64)
        pred = np.asarray(s.pred, dtype=np.int64)
        filled = fill_ignore(truth)
        keep = transition_mask(filled, s.fps, exclude_s) & (truth >= 0)
        t_k, p_k, k_k = truth[keep], pred[keep], false_movement_kinds(filled, pred)[keep]
        if s.contacts is None:
            c_k = np.full(t_k.shape, -1, dtype=np.int8)
        else:
            both: NDArray[np.int8] = np.asarray(np.all(np.asarray(s.contacts, dtype=bool), axis=1), np.int8)
            c_k = both[keep]
        conf += confusion(t_k, p_k)
        lat = latencies(filled, pred, s.fps)
        starts += [float(v) for v in lat.start_s if np.isfinite(v)]
        n_start_missed += int(np.sum(~np.isfinite(lat.start_s)))
        pauses = rhythm_pauses_s(filled != _STILL, s.contacts, s.fps)
        for k, v in enumerate(lat.stop_s.tolist()):  # the k-th stop ends the k-th bout
            if np.isfinite(v):
                stops.append(float(v))
                allow = pauses[k] if k < len(pauses) else 0.0
                beyond.append(max(0.0, float(v) - allow))
            else:
                n_stop_missed += 1
        true_changes += int(np.sum(filled[1:] != filled[:-1]))
        pred_changes += int(np.sum(pred[1:] != pred[:-1]))
        tags = np.asarray(s.tags).astype(str)[keep]
        for tag in np.unique(tags).tolist():
            sel = tags == tag
            by_tag.setdefault(tag or UNTAGGED, []).append((t_k[sel], p_k[sel], k_k[sel], c_k[sel]))
        per_seq.append(_group(s.name, t_k, p_k, k_k, c_k))
        by_src.setdefault(s.source, []).append((t_k, p_k, k_k, c_k))

    def joined(name: str, parts: list[Part]) -> GroupStats:
        if not parts:
            empty = np.zeros(0, np.int8)
            return _group(name, np.zeros(0, np.int64), np.zeros(0, np.int64), empty, empty)
        return _group(name, *(np.concatenate([part[i] for part in parts]) for i in range(4)))

    def groups(by: dict[str, list[Part]]) -> tuple[GroupStats, ...]:
        return tuple(joined(k, by[k]) for k in sorted(by))

    return Evaluation(
        confusion=conf,
        start=LatencyStats(tuple(starts), n_start_missed),
        stop=LatencyStats(tuple(stops), n_stop_missed),
        stop_beyond_rhythm=LatencyStats(tuple(beyond), n_stop_missed),
        overall=joined("all", [part for parts in by_src.values() for part in parts]),
        per_tag=groups(by_tag),
        per_sequence=tuple(per_seq),
        per_source=groups(by_src),
        true_changes=true_changes,
        predicted_changes=pred_changes,
        exclude_s=exclude_s,
    )


def _pct(v: float | None) -> str:
    return "—" if v is None else f"{100 * v:.2f} %"


def _ms(v: float | None) -> str:
    return "—" if v is None else f"{1000 * v:.0f}"


def text_report(ev: Evaluation) -> str:
    """The evaluation as text tables (what `cavewalk evaluate` prints)."""
    lines = [
        f"frames scored: {ev.frames} ({1000 * ev.exclude_s:.0f} ms after each true change and "
        "'ignore' frames left out)",
        f"frame accuracy {_pct(ev.accuracy)}, macro-F1 "
        + ("—" if ev.macro_f1 is None else f"{ev.macro_f1:.3f}"),
        "",
        f"{'class':<10}{'precision':>11}{'recall':>9}{'F1':>8}{'support':>9}",
    ]
    for name, c in ev.per_class().items():
        f = "—" if c["f1"] is None else f"{c['f1']:.3f}"
        p = "—" if c["precision"] is None else f"{c['precision']:.3f}"
        r = "—" if c["recall"] is None else f"{c['recall']:.3f}"
        lines.append(f"{name:<10}{p:>11}{r:>9}{f:>8}{c['support']:>9}")
    lines += ["", text_confusion(ev.confusion), ""]
    for title, lat in (
        ("start latency", ev.start),
        ("stop latency", ev.stop),
        ("stop latency beyond the rhythm's pause", ev.stop_beyond_rhythm),
    ):
        lines.append(
            f"{title}: n={lat.n} median {_ms(lat.median_s)} ms, p95 {_ms(lat.p95_s)} ms, missed {lat.missed}"
        )
    o = ev.overall
    lines += [
        "",
        f"false movement (truly still frames predicted moving): {_pct(o.false_movement)} "
        f"of {o.still_frames}; movement detected: {_pct(o.movement_detected)} "
        f"of {o.moving_frames} moving frames",
        f"  of the still frames: held on after a bout {_pct(o.false_after_bout)}, begun before a bout "
        f"{_pct(o.false_before_bout)}, false starts (a command with no bout) {_pct(o.false_starts)}",
        "  with both feet planted (the files' contacts): "
        + (f"{_pct(o.false_movement_planted)} of {o.still_planted}" if o.still_planted is not None
           else "— (no contacts in the files)"),
        "command changes per true change: " + ("—" if ev.flicker is None else f"{ev.flicker:.2f}"),
        "",
    ]
    for title, rows in (("tag", ev.per_tag), ("source", ev.per_source), ("sequence", ev.per_sequence)):
        w = max([len(title), *(len(g.name) for g in rows)]) + 2
        lines.append(
            f"{title:<{w}}{'frames':>8}{'accuracy':>10}{'still':>8}{'false mov.':>12}"
            f"{'false st.':>11}{'planted':>10}{'moving':>8}{'detected':>10}"
        )
        for g in rows:
            lines.append(
                f"{g.name:<{w}}{g.frames:>8}{_pct(g.accuracy):>10}{g.still_frames:>8}"
                f"{_pct(g.false_movement):>12}{_pct(g.false_starts):>11}{_pct(g.false_movement_planted):>10}"
                f"{g.moving_frames:>8}{_pct(g.movement_detected):>10}"
            )
        lines.append("")
    return "\n".join(lines).rstrip() + "\n"
