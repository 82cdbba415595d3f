#!/usr/bin/env python
"""Write a set of labelled skeleton sequences from the gait model (pipeline.sim.gait).

    python scripts/make_gait_set.py --out DIR --seed S --count N --duration-s D [--fps F]
        [--noise-m 0.012] [--dropout 0.02] [--preset default|in-place] [--plot]

Sequence i uses the seed derived from (S, i), so sets made with different S do not share
sequences. Each file ``gait_S_i.npz`` is a SPEC skeleton NPZ with ``labels``, ``tags``,
``contacts`` and ``source="gait"``; ``index.json`` lists the files with their body height
and frames per label. ``--preset in-place`` draws only stepping in place and what people do
standing between bouts (pipeline.sim.gait.IN_PLACE_MIX). ``--plot`` also writes a PNG per
file (ankle heights, labels, tags).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pipeline.sim.gait import IN_PLACE_MIX, IN_PLACE_SIDE_KINDS, GaitConfig, simulate_routine
from pipeline.skeleton import J, save_npz


def sequence_seed(seed: int, index: int) -> int:
    return int(np.random.SeedSequence([seed, index]).generate_state(1)[0])


def plot(path: Path, joints: np.ndarray, labels: tuple[str, ...], tags: tuple[str, ...], fps: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.arange(len(labels)) / fps
    fig, ax = plt.subplots(2, 1, figsize=(16, 5), sharex=True)
    ax[0].plot(t, joints[:, J["l_ankle"], 2], lw=0.8, label="left ankle z")
    ax[0].plot(t, joints[:, J["r_ankle"], 2], lw=0.8, label="right ankle z")
    ax[0].set_ylabel("m")
    ax[0].legend(loc="upper right")
    lab = np.array(labels)
    for name, colour in (("still", "C0"), ("forward", "C1"), ("left", "C2"), ("right", "C3")):
        ax[1].fill_between(t, 0, 1, where=lab == name, color=colour, alpha=0.5, label=name)
    prev = ""
    for i, tag in enumerate(tags):
        if tag and tag != prev:
            ax[1].text(t[i], 0.55, tag, fontsize=6, rotation=60)
        prev = tag
    ax[1].legend(loc="upper right")
    ax[1].set_xlabel("s")
    fig.savefig(path, dpi=70)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--duration-s", type=float, default=60.0)
    ap.add_argument("--fps", type=float, default=30.0)
    ap.add_argument("--noise-m", type=float, default=0.0)
    ap.add_argument("--dropout", type=float, default=0.0)
    ap.add_argument("--preset", choices=("default", "in-place"), default="default")
    ap.add_argument("--plot", action="store_true")
    args = ap.parse_args(argv)
    if args.count < 1:
        ap.error(f"--count must be at least 1, got {args.count}")
    if not (math.isfinite(args.duration_s) and args.duration_s > 0):
        ap.error(f"--duration-s must be a positive number, got {args.duration_s}")
    if args.out.exists() and not args.out.is_dir():
        ap.error(f"--out {args.out} is a file, not a folder")
    try:
        config = GaitConfig(
            fps=args.fps, duration_s=args.duration_s, noise_m=args.noise_m, dropout=args.dropout
        )
        if args.preset == "in-place":
            config = GaitConfig(
                fps=args.fps, duration_s=args.duration_s, noise_m=args.noise_m, dropout=args.dropout,
                mix=IN_PLACE_MIX, side_kinds=IN_PLACE_SIDE_KINDS,
            )
    except ValueError as exc:
        ap.error(str(exc))
    args.out.mkdir(parents=True, exist_ok=True)
    index = []
    total: Counter[str] = Counter()
    for i in range(args.count):
        seed = sequence_seed(args.seed, i)
        take = simulate_routine(config, seed)
        seq = take.sequence
        name = f"gait_{args.seed}_{i:03d}.npz"
        save_npz(args.out / name, seq)
        counts = Counter(seq.labels or ())
        total.update(counts)
        index.append({
            "file": name, "seed": seed, "frames": len(seq), "fps": seq.fps,
            "height_m": round(take.body.height_m, 3), "labels": dict(counts),
            "tags": dict(Counter(t for t in (seq.tags or ()) if t)),
        })
        if args.plot:
            png = args.out / name.replace(".npz", ".png")
            plot(png, take.solved.joints, seq.labels or (), seq.tags or (), seq.fps)
        print(f"{name}: {len(seq)} frames, height {take.body.height_m:.2f} m, "
              + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    (args.out / "index.json").write_text(json.dumps({
        "source": "gait", "seed": args.seed, "config": {
            "fps": config.fps, "duration_s": config.duration_s, "noise_m": config.noise_m,
            "dropout": config.dropout, "preset": args.preset,
        }, "files": index,
    }, indent=1))
    print(f"{args.count} sequences in {args.out}; frames per label: "
          + ", ".join(f"{k} {v}" for k, v in sorted(total.items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
