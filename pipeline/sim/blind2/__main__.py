"""``python -m pipeline.sim.blind2 OUT_DIR [--count N] [--seed S] [--summary]``: write the blind2 set.

Held-out evaluation data for the action recogniser (the default seed: never train on it; the
action model trains on other seeds, ``--source blind2``). Its generator was written
independently of the product's motion models. The default set (seed 2026, 12 sequences of 60 s)
is the ``blind2-heldout`` source.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path
from typing import NoReturn

from pipeline.errors import CavewalkError, InputError
from pipeline.sim.blind2.generate import (
    DEFAULT_COUNT,
    DEFAULT_DURATION_S,
    DEFAULT_SEED,
    Generated,
    SetConfig,
    check_folder,
    generate_set,
    save_set,
)


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are InputError (one ``error:`` line, exit 2)."""

    def error(self, message: str) -> NoReturn:
        raise InputError(message)


def _summary(sequences: list[Generated]) -> list[str]:
    labels: Counter[str] = Counter()
    tags: Counter[tuple[str, str]] = Counter()
    for g in sequences:
        labels.update(str(x) for x in g.labels)
        tags.update(zip((str(x) for x in g.labels), (str(x) for x in g.tags), strict=True))
    lines = [f"frames per label: {dict(sorted(labels.items()))}"]
    lines += [f"  {label:8s} {tag or '(none)':20s} {n:6d}" for (label, tag), n in sorted(tags.items())]
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = _Parser(
        prog="python -m pipeline.sim.blind2",
        description="Write skeleton NPZ files from the blind2 generator (the default seed is the "
        "held-out set: never train on it; written independently of the product's motion models).",
    )
    ap.add_argument("out_dir", type=Path, help="folder for the NPZ files")
    ap.add_argument(
        "--count", type=int, default=DEFAULT_COUNT, help=f"number of sequences (default {DEFAULT_COUNT})"
    )
    ap.add_argument("--seed", type=int, default=DEFAULT_SEED, help=f"random seed (default {DEFAULT_SEED})")
    ap.add_argument(
        "--duration",
        type=float,
        default=DEFAULT_DURATION_S,
        help=f"seconds per sequence (default {DEFAULT_DURATION_S:g}; the held-out set uses the default)",
    )
    ap.add_argument("--summary", action="store_true", help="print frames per label and per tag")
    try:
        args = ap.parse_args(argv)
        config = SetConfig(count=args.count, seed=args.seed, duration_s=args.duration)
        check_folder(args.out_dir)
        sequences = generate_set(config)
        paths = save_set(args.out_dir, sequences, config.seed)
    except (CavewalkError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    if args.summary:
        for line in _summary(sequences):
            print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
