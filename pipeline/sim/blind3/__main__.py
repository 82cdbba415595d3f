"""``python -m pipeline.sim.blind3 OUT_DIR [--count N] [--seed S] [--duration D]``: write a blind3 set.

Held-out evaluation data for the action recogniser (the default seed: never train on it; the
action model trains on other seeds, ``--source blind3``). Its generator was written
independently of the product's motion models. The default set (seed 31337, 12 sequences of 60 s)
is the reference held-out set; ``python -m pipeline.sim.blind3.check OUT_DIR`` checks a written set.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import NoReturn

from pipeline.errors import CavewalkError, InputError
from pipeline.sim.blind3.api import DEFAULT_COUNT, DEFAULT_DURATION_S, DEFAULT_SEED, write_set


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are InputError (one ``error:`` line, exit 2)."""

    def error(self, message: str) -> NoReturn:
        raise InputError(message)


def main(argv: list[str] | None = None) -> int:
    ap = _Parser(
        prog="python -m pipeline.sim.blind3",
        description="Write skeleton NPZ files from the blind3 generator (the default seed is the "
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
    try:
        args = ap.parse_args(argv)
        # write_set refuses bad values before it writes anything
        paths = write_set(args.out_dir, count=args.count, seed=args.seed, duration_s=args.duration)
    except (CavewalkError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
