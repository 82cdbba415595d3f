#!/usr/bin/env python
"""How well the step evidence sees the feet: contact accuracy and lift-off / touch-down timing
against the ground-truth ``contacts`` of labelled NPZ files.

    .venv/bin/python scripts/eval_steps.py A.npz B.npz ... [--capture] [--json OUT]

``--capture`` first passes each clean sequence through the simulated CAVE cameras and our
triangulation (the training data's capture faults). Events are matched to true events of the same
foot within 0.25 s; unmatched detections are false events, unmatched true ones missed.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.recognition.corpus import resample  # noqa: E402
from pipeline.recognition.dataset import load_labelled  # noqa: E402
from pipeline.recognition.steps import step_evidence  # noqa: E402
from pipeline.recognition.train import NoiseConfig, captured  # noqa: E402

TOL_S = 0.25


def true_events(contacts: np.ndarray, fps: float) -> tuple[list[tuple[float, int]], list[tuple[float, int]]]:
    lifts, lands = [], []
    for k in (0, 1):
        c = contacts[:, k].astype(int)
        d = np.diff(c)
        lifts += [((i + 1) / fps, k) for i in np.flatnonzero(d == -1)]
        lands += [((i + 1) / fps, k) for i in np.flatnonzero(d == 1)]
    return lifts, lands


def match(true: list[tuple[float, int]], found: np.ndarray) -> tuple[list[float], int, int]:
    """(timing errors of matched events, missed, false)."""
    used = np.zeros(len(found), dtype=bool)
    errs = []
    missed = 0
    for t, k in true:
        cand = (
            np.flatnonzero((found[:, 1] == k) & ~used & (np.abs(found[:, 0] - t) <= TOL_S))
            if len(found)
            else []
        )
        if len(cand) == 0:
            missed += 1
            continue
        best = cand[np.argmin(np.abs(found[cand, 0] - t))]
        used[best] = True
        errs.append(float(found[best, 0] - t))
    return errs, missed, int((~used).sum())


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", type=Path)
    ap.add_argument("--capture", action="store_true")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()
    seqs = [resample(load_labelled(p), 30.0) for p in args.files]
    seqs = [s for s in seqs if s.contacts is not None]
    if not seqs:
        raise SystemExit("error: no file has ground-truth contacts")
    if args.capture:
        seqs = captured(seqs, NoiseConfig(), seed=17)
    agree = total = 0
    lift_err: list[float] = []
    land_err: list[float] = []
    counts = {"lifts": 0, "lands": 0, "lift_missed": 0, "land_missed": 0, "lift_false": 0, "land_false": 0}
    per_tag: dict[str, list[int]] = {}
    for s in seqs:
        ev = step_evidence(s.joints_m, s.fps)
        c = np.asarray(s.contacts, dtype=bool)
        ok = ev.planted == c
        agree += int(ok.sum())
        total += ok.size
        for tag in np.unique(s.tags):
            sel = s.tags == tag
            a = per_tag.setdefault(str(tag) or "(untagged)", [0, 0])
            a[0] += int(ok[sel].sum())
            a[1] += int(ok[sel].size)
        tl, td = true_events(c, s.fps)
        e, m, f = match(tl, ev.lifts)
        lift_err += e
        counts["lifts"] += len(tl)
        counts["lift_missed"] += m
        counts["lift_false"] += f
        e, m, f = match(td, ev.lands)
        land_err += e
        counts["lands"] += len(td)
        counts["land_missed"] += m
        counts["land_false"] += f

    def q(v: list[float]) -> dict[str, float]:
        a = np.abs(v)
        return {"median_abs_ms": 1000 * float(np.median(a)), "p95_abs_ms": 1000 * float(np.percentile(a, 95)),
                "mean_ms": 1000 * float(np.mean(v))}  # fmt: skip

    out = {
        "sequences": len(seqs),
        "frames": total // 2,
        "captured": args.capture,
        "contact_accuracy": agree / total,
        "lift_timing": q(lift_err),
        "land_timing": q(land_err),
        **counts,
        "contact_accuracy_per_tag": {k: v[0] / v[1] for k, v in sorted(per_tag.items())},
    }
    lt, dt = out["lift_timing"], out["land_timing"]
    print(
        f"{len(seqs)} sequences, {total // 2} frames{' (captured)' if args.capture else ''}: "
        f"contact accuracy {out['contact_accuracy']:.3f}"
    )
    for name, c, tm in (("lift-offs", "lift", lt), ("touch-downs", "land", dt)):
        print(
            f"{name}: {counts[c + 's']} true, missed {counts[c + '_missed']}, false {counts[c + '_false']}, "
            f"timing |err| median {tm['median_abs_ms']:.0f} ms, p95 {tm['p95_abs_ms']:.0f} ms, "  # type: ignore[index]
            f"mean {tm['mean_ms']:+.0f} ms"  # type: ignore[index]
        )
    for k, v in out["contact_accuracy_per_tag"].items():  # type: ignore[union-attr]
        print(f"  {k:<24} contact accuracy {v:.3f}")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
