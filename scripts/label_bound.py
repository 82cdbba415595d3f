#!/usr/bin/env python
"""What a causal recogniser could reach at best on a labelled set, given its labelling rule.

    .venv/bin/python scripts/label_bound.py DIR [DIR ...] [--hold 0.2 0.3 ... ] [--lag 0 0.1 ...]

An oracle that knows every ground-truth foot contact, which swings are steps of a bout (the label at
the lift-off) and each bout's direction starts moving at the first lift-off (no latency) and stops
``hold`` seconds after the last touch-down unless another lift-off comes first: the best fixed
pause a streaming recogniser can hold, since it cannot know whether a pause ends the bout or not.
Scored with :func:`pipeline.recognition.metrics.evaluate` (``cavewalk evaluate``'s figures), so its
accuracy is a ceiling for any recogniser that holds a fixed pause on a set whose labels keep
pauses of up to 1 s inside a bout (our generators' rule): a longer hold wins the pauses and loses
the stops, a shorter one the reverse.

``--lag``: the same oracle seeing each lift-off ``lag`` seconds late (a step tracker must wait
until the foot has risen clear of the capture noise): its command starts that much later and a
pause ends the bout unless the next lift-off is seen within the hold, so a pause of P needs a hold
of P + lag. The distance between ``--lag 0`` and the tracker's real delay is what faster lift-off
detection could win.

``--visible M``: swings whose ankle never moves ``M`` metres from where it lifted off (a centred
five-frame mean of the file's joints, so the capture noise is part of it) count as contact: the
oracle knows only the swings a camera could show. Some generators unload a foot without moving it
(29 % of blind6's side-step swings move the ankle less than 3 cm, noise included); an oracle that
sees those has room that no recogniser working from the skeleton has.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from loso_action import summary  # noqa: E402

from pipeline.recognition import corpus  # noqa: E402
from pipeline.recognition.dataset import LabelledSequence  # noqa: E402
from pipeline.recognition.metrics import ScoredSequence, evaluate  # noqa: E402
from pipeline.skeleton import J  # noqa: E402

_ANKLES = (J["l_ankle"], J["r_ankle"])


def seen_swings(contacts: np.ndarray, lag_frames: int) -> np.ndarray:
    """(T, 2) True where a foot is up and its swing has been seen: from ``lag_frames`` after each
    lift-off to its touch-down (a swing shorter than the lag is never seen)."""
    up = ~np.asarray(contacts, dtype=bool)
    seen = up.copy()
    for k in (0, 1):
        starts = np.flatnonzero(up[:, k] & ~np.r_[False, up[:-1, k]])
        for a in starts.tolist():
            seen[a : a + lag_frames, k] = False
    return seen


def _centred_mean(points: np.ndarray, half: int = 2) -> np.ndarray:
    """(T, 3) mean of each point and its ``half`` neighbours either side, unknown (NaN) ones left
    out; NaN where all are unknown."""
    known = np.isfinite(points).all(axis=1)
    filled = np.where(known[:, None], points, 0.0)
    c = np.concatenate([np.zeros((1, 3)), np.cumsum(filled, axis=0)])
    n = np.concatenate([[0], np.cumsum(known)])
    idx = np.arange(len(points))
    lo, hi = np.clip(idx - half, 0, len(points)), np.clip(idx + half + 1, 0, len(points))
    count = (n[hi] - n[lo])[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, (c[hi] - c[lo]) / np.maximum(count, 1), np.nan)


def visible_contacts(joints: np.ndarray, contacts: np.ndarray, min_m: float) -> np.ndarray:
    """``contacts`` with every swing whose ankle never moved ``min_m`` metres from its lift-off point
    (centred five-frame means) turned back into contact: a swing no camera could show."""
    out = np.asarray(contacts, dtype=bool).copy()
    for k, ankle in enumerate(_ANKLES):
        pos = _centred_mean(np.asarray(joints, dtype=np.float64)[:, ankle])
        up = ~out[:, k]
        edges = np.flatnonzero(np.diff(np.r_[0, up.astype(np.int8), 0]))
        for a, b in zip(edges[::2].tolist(), edges[1::2].tolist(), strict=True):
            before = pos[max(0, a - 4) : a + 1]
            before = before[np.isfinite(before).all(axis=1)]
            moved = np.linalg.norm(pos[a:b] - before.mean(axis=0), axis=1) if len(before) else np.array([])
            if not (moved[np.isfinite(moved)] >= min_m).any():
                out[a:b, k] = True
    return out


def oracle(seq: LabelledSequence, hold_s: float, lag_s: float = 0.0) -> np.ndarray:
    """The oracle's command per frame (class index) for one sequence with ground-truth contacts,
    seeing each lift-off ``lag_s`` late."""
    if seq.contacts is None:
        raise SystemExit(f"error: {seq.name} has no ground-truth contacts")
    lab = seq.labels
    lag = round(lag_s * seq.fps)
    up = seen_swings(seq.contacts, lag)
    pred = np.zeros(len(lab), dtype=np.int64)
    active, last_down, current = False, -np.inf, 0
    for i in range(1, len(lab)):
        t = i / seq.fps
        if any(up[i, k] and not up[i - 1, k] for k in (0, 1)) and lab[i - lag] > 0:
            active, current = True, int(lab[i - lag])  # a lift-off inside a bout: a step of it
        if up[i].any():
            last_down = t  # a foot is up: the pause has not begun
        elif active and t - last_down > hold_s:
            active = False
        pred[i] = current if active else 0
    return pred


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--hold", nargs="+", type=float, default=[0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.2])
    ap.add_argument("--lag", nargs="+", type=float, default=[0.0], help="lift-off seen this late (s)")
    ap.add_argument(
        "--visible", type=float, default=None, metavar="M", help="swings moving under M metres are contact"
    )
    args = ap.parse_args()
    bad = [v for v in [*args.hold, *args.lag] if not (np.isfinite(v) and 0.0 <= v <= 5.0)]
    if bad:
        print(f"error: --hold and --lag are seconds in [0, 5], got {bad}", file=sys.stderr)
        return 2
    if args.visible is not None and not (np.isfinite(args.visible) and 0.0 < args.visible <= 0.5):
        print(f"error: --visible is metres in (0, 0.5], got {args.visible}", file=sys.stderr)
        return 2
    for folder in args.folders:
        if not folder.is_dir():
            print(f"error: {folder} is not a folder", file=sys.stderr)
            return 2
    for folder in args.folders:
        seqs = [corpus.resample(s, 30.0) for s in corpus.from_folder(folder)]
        if args.visible is not None:
            seqs = [
                dataclasses.replace(s, contacts=visible_contacts(s.joints_m, s.contacts, args.visible))
                if s.contacts is not None
                else s
                for s in seqs
            ]
        for lag, hold in ((lag, hold) for lag in args.lag for hold in args.hold):
            scored = [
                ScoredSequence(s.name, s.source, s.labels, oracle(s, hold, lag), s.tags, s.fps, s.contacts)
                for s in seqs
            ]
            m = summary(evaluate(scored))
            seen = f" lag {lag:.2f} s" if lag else ""
            print(
                f"{folder.name:>16}{seen} hold {hold:.1f} s: "
                f"accuracy {m['accuracy']} macro-F1 {m['macro_f1']} "
                f"false movement {m['false_movement']} detected {m['movement_detected']} "
                f"stop beyond rhythm {m['stop_beyond_rhythm_median_s']}/{m['stop_beyond_rhythm_p95_s']} s"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
