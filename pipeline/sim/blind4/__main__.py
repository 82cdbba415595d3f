"""``python -m pipeline.sim.blind4 OUT_DIR [--count N] [--seed S] [--duration D]``: write a blind4 set.

Held-out evaluation data for the action recogniser: never train on it. Its generator was written
without reading the product's code. The default set (seed 60606, 12 sequences of 60 s) is the
reference held-out set; ``python -m pipeline.sim.blind4.check OUT_DIR`` checks a written set.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import NoReturn

from pipeline.errors import CavewalkError, InputError
from pipeline.sim.blind4.sequence import DEFAULT_COUNT, DEFAULT_DURATION_S, DEFAULT_SEED, write_set


class _Parser(argparse.ArgumentParser):
    """An argument parser whose usage errors are InputError (one ``error:`` line, exit 2)."""

    def error(self, message: str) -> NoReturn:
        raise InputError(message)


def main(argv: list[str] | None = None) -> int:
    """Write a set of sequences and print a short summary."""
    ap = _Parser(
        prog="python -m pipeline.sim.blind4",
        description="Write skeleton NPZ files from the blind4 generator (held-out evaluation data; "
        "never train on it; written without reading the product's code).",
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
    t0 = time.perf_counter()
    try:
        args = ap.parse_args(argv)
        # write_set refuses bad values before it writes anything
        paths = write_set(args.out_dir, args.count, args.seed, args.duration)
    except (CavewalkError, ValueError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    dt = time.perf_counter() - t0
    print(f"wrote {len(paths)} files to {args.out_dir} in {dt:.1f} s ({dt / len(paths):.2f} s per sequence)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
