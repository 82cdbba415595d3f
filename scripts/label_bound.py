#!/usr/bin/env python
"""What a causal recogniser could reach at best on a labelled set, given its labelling rule.

    .venv/bin/python scripts/label_bound.py DIR [DIR ...] [--hold 0.2 0.3 ... ]

An oracle that knows every ground-truth foot contact, which swings are steps of a bout (the label at
the lift-off) and each bout's direction starts moving at the first lift-off (no latency) and stops
``hold`` seconds after the last touch-down unless another lift-off comes first: the best fixed
pause a streaming recogniser can hold, since it cannot know whether a pause ends the bout or not.
Scored with :func:`pipeline.recognition.metrics.evaluate` (``cavewalk evaluate``'s figures), so its
accuracy is a ceiling for any recogniser that holds a fixed pause on a set whose labels keep
pauses of up to 1 s inside a bout (our generators' rule): a longer hold wins the pauses and loses
the stops, a shorter one the reverse.
"""

from __future__ import annotations

import argparse
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


def oracle(seq: LabelledSequence, hold_s: float) -> np.ndarray:
    """The oracle's command per frame (class index) for one sequence with ground-truth contacts."""
    if seq.contacts is None:
        raise SystemExit(f"error: {seq.name} has no ground-truth contacts")
    c, lab = np.asarray(seq.contacts, dtype=bool), seq.labels
    pred = np.zeros(len(lab), dtype=np.int64)
    active, last_down, current = False, -np.inf, 0
    for i in range(1, len(lab)):
        t = i / seq.fps
        if any(c[i - 1, k] and not c[i, k] for k in (0, 1)) and lab[i] > 0:
            active, current = True, int(lab[i])  # a lift-off inside a bout: a step of it
        if not c[i].all():
            last_down = t  # a foot is up: the pause has not begun
        elif active and t - last_down > hold_s:
            active = False
        pred[i] = current if active else 0
    return pred


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("folders", nargs="+", type=Path)
    ap.add_argument("--hold", nargs="+", type=float, default=[0.2, 0.3, 0.4, 0.5, 0.6, 0.8, 1.0, 1.2])
    args = ap.parse_args()
    for folder in args.folders:
        seqs = [corpus.resample(s, 30.0) for s in corpus.from_folder(folder)]
        for hold in args.hold:
            scored = [
                ScoredSequence(s.name, s.source, s.labels, oracle(s, hold), s.tags, s.fps, s.contacts)
                for s in seqs
            ]
            m = summary(evaluate(scored))
            print(
                f"{folder.name:>16} hold {hold:.1f} s: accuracy {m['accuracy']} macro-F1 {m['macro_f1']} "
                f"false movement {m['false_movement']} detected {m['movement_detected']} "
                f"stop beyond rhythm {m['stop_beyond_rhythm_median_s']}/{m['stop_beyond_rhythm_p95_s']} s"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
