"""``python -m pipeline.sim.blind OUT_DIR [--count N] [--seed S]``: write a held-out evaluation set."""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

from pipeline.errors import CavewalkError
from pipeline.sim.blind.figure import plot_check
from pipeline.sim.blind.generate import DEFAULT_SEED, NoiseConfig, generate_set, save_set
from pipeline.skeleton import load_npz


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m pipeline.sim.blind",
        description="Write skeleton NPZ files from the blind generator "
        "(the default seed is the held-out set: never train on it).",
    )
    ap.add_argument("out_dir", type=Path, help="folder for the NPZ files")
    ap.add_argument("--count", type=int, default=12, help="number of people / sequences (default 12)")
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"random seed (default {DEFAULT_SEED})")
    ap.add_argument("--duration", type=float, default=60.0, help="seconds per sequence (default 60)")
    ap.add_argument("--noise", type=float, default=0.012, help="joint noise sd in metres (default 0.012)")
    ap.add_argument(
        "--dropout", type=float, default=0.02, help="fraction of joints dropped to NaN (default 0.02)"
    )
    ap.add_argument("--summary", action="store_true", help="print frames per label and per tag")
    ap.add_argument("--figure", type=Path, help="also save a check figure (PNG) of the first sequence here")
    args = ap.parse_args(argv)
    try:
        noise = NoiseConfig(noise_m=args.noise, dropout=args.dropout)
        sequences = generate_set(args.count, args.duration, args.seed, noise)
        paths = save_set(args.out_dir, sequences, args.seed)
    except (CavewalkError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    if args.figure is not None:
        print(plot_check(sequences[0], args.figure))
    if args.summary:
        labels: Counter[str] = Counter()
        tags: Counter[tuple[str, str]] = Counter()
        for p in paths:
            seq = load_npz(p)
            labels.update(seq.labels or ())
            tags.update(zip(seq.labels or (), seq.tags or (), strict=True))
        print("frames per label:", dict(sorted(labels.items())))
        for (label, tag), n in sorted(tags.items()):
            print(f"  {label:8s} {tag or '(none)':20s} {n:6d}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
