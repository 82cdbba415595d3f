"""Physical sanity of the simulator, per behaviour: a table (and JSON) of what it really does.

For each behaviour, ``--seeds`` people (bodies 1.40-2.05 m, own styles) do it for a few seconds
between two moments of standing. Reported per behaviour:

- slide_mm: the largest distance a planted foot's ankle moves over the floor in one frame
  (contact True in both frames); marching with ``slide_m`` and pivot turns glide on purpose;
- bone_mm: the largest change of a rigid bone's length (limbs, face, shoulders, pelvis);
- lifted: share of the behaviour's frames with a foot off the floor; airborne: with both;
- pause_s: the longest both-feet-down interval inside a stepping bout (LABELS: <= 1.0 s);
- cadence_err: |realised - asked| / asked for stepping with a scripted cadence;
- knee_min_m: the lowest knee (kneeling: on the floor).

    python scripts/check_sim.py [--seeds 20] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

from pipeline.sim.behaviours import LIBRARY
from pipeline.sim.body import sample_body, sample_style
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.skeleton import BONES, J

FPS = 30.0
ANKLES = [J["l_ankle"], J["r_ankle"]]
KNEES = [J["l_knee"], J["r_knee"]]
RIGID = [
    (a, b) for a, b in BONES if {a, b} not in ({J["l_shoulder"], J["l_hip"]}, {J["r_shoulder"], J["r_hip"]})
]

STEPPING: dict[str, Segment] = {
    "march": Segment("forward", 5.0, behaviour="march", cadence_steps_per_s=1.8, slide_m=0.0),
    "march-slow-high": Segment("forward", 5.0, cadence_steps_per_s=0.6, knee_lift_m=0.3, slide_m=0.0),
    "march-fast-low": Segment("forward", 5.0, cadence_steps_per_s=2.6, knee_lift_m=0.03, slide_m=0.0),
    "march-slide": Segment("forward", 5.0, cadence_steps_per_s=1.5, slide_m=0.06),
    "march-pauses": Segment("forward", 5.0, cadence_steps_per_s=2.0, pause_prob=0.5, slide_m=0.0),
    "march-irregular": Segment(
        "forward", 5.0, cadence_steps_per_s=1.6, irregularity=0.3, asymmetry=1.4, slide_m=0.0
    ),
    "walk": Segment("forward", 3.0, behaviour="walk", travel_mps=1.0),
    "run": Segment("forward", 2.0, behaviour="run", travel_mps=2.4),
    "side-step-out-back": Segment("left", 5.0, behaviour="side-step-out-back", cadence_steps_per_s=1.6),
    "step-together": Segment("right", 4.0, behaviour="step-together", cadence_steps_per_s=1.6),
    "shuffle": Segment("left", 4.0, behaviour="shuffle", cadence_steps_per_s=1.8),
    "turn": Segment("turn", 2.0, turn_deg=150.0),
}


def measure(name: str, seg: Segment, seed: int) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    segs = (Segment("still", 1.0, gestures=()), seg, Segment("still", 1.0, gestures=()))
    script = MotionScript(segs, start_yaw_deg=float(rng.uniform(-180, 180)))
    m = simulate_user(script, sample_body(rng), FPS, seed=seed, style=sample_style(rng))
    part = slice(30, 30 + round(seg.duration_s * FPS))
    step = np.linalg.norm(np.diff(m.joints_m[:, ANKLES, :2], axis=0), axis=-1)
    slide = np.where(m.contacts[1:] & m.contacts[:-1], step, 0.0).max()
    lengths = np.stack([np.linalg.norm(m.joints_m[:, a] - m.joints_m[:, b], axis=-1) for a, b in RIGID], 1)
    off = ~m.contacts[part]
    out = {
        "slide_mm": 1000 * float(slide),
        "bone_mm": 1000 * float(np.ptp(lengths, axis=0).max()),
        "lifted": float(off.any(axis=1).mean()),
        "airborne": float(off.all(axis=1).mean()),
        "knee_min_m": float(m.joints_m[:, KNEES, 2].min()),
        "pause_s": float("nan"),
        "cadence_err": float("nan"),
    }
    if seg.label != "still":
        down = np.concatenate([[0], m.contacts[part].all(axis=1).astype(int), [0]])
        edges = np.flatnonzero(np.diff(down))
        runs = (edges[1::2] - edges[::2]) / FPS
        out["pause_s"] = float(runs[1:-1].max()) if len(runs) > 2 else 0.0
        if seg.cadence_steps_per_s is not None:
            feet = (
                [0 if seg.action == "left" else 1] if seg.behaviour_name == "side-step-out-back" else [0, 1]
            )
            c = m.contacts[part][:, feet]  # out-and-back: the leading foot's steps (not the other's taps)
            lifts = np.flatnonzero((c[:-1] & ~c[1:]).any(axis=1)) + 1
            lifts = np.concatenate([[0], lifts]) / FPS
            got = (len(lifts) - 1) / (lifts[-1] - lifts[0])
            out["cadence_err"] = abs(got - seg.cadence_steps_per_s) / seg.cadence_steps_per_s
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args(argv)
    if args.seeds < 1:
        print("error: --seeds must be at least 1", file=sys.stderr)
        return 2
    cases = dict(STEPPING)
    cases.update(
        {
            name: Segment("still", 5.0 if name in ("kneel", "dance-on-spot") else 4.0, behaviour=name)
            for name in sorted(LIBRARY)
        }
    )
    report: dict[str, dict[str, float]] = {}
    cols = ["slide_mm", "bone_mm", "lifted", "airborne", "pause_s", "cadence_err", "knee_min_m"]
    print(f"{'behaviour':20s} " + " ".join(f"{c:>11s}" for c in cols))
    for name, seg in cases.items():
        rows = [measure(name, seg, seed) for seed in range(args.seeds)]
        agg = {}
        for c in cols:
            vals = np.array([r[c] for r in rows])
            agg[c] = (
                float(np.nanmin(vals))
                if c == "knee_min_m"
                else float(np.nanmax(vals))
                if np.isfinite(vals).any()
                else float("nan")
            )
        report[name] = agg
        print(f"{name:20s} " + " ".join(f"{agg[c]:11.3f}" for c in cols))
    if args.json is not None:
        args.json.write_text(json.dumps({"seeds": args.seeds, "fps": FPS, "behaviours": report}, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
