"""python -m pipeline.sim.blind5 OUT_DIR [--count N] [--seed S] [--duration SECONDS]"""

import argparse
import sys

from pipeline.sim.blind5 import validate_args, write_set


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        print(f"error: {message}", file=sys.stderr)
        sys.exit(2)


def main(argv=None):
    ap = _Parser(prog="python -m pipeline.sim.blind5", description=__doc__)
    ap.add_argument("out_dir")
    ap.add_argument("--count", type=int, default=12)
    ap.add_argument("--seed", type=int, default=50505)
    ap.add_argument("--duration", type=float, default=60.0)
    a = ap.parse_args(argv)
    try:
        validate_args(a.count, a.seed, a.duration)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        paths = write_set(a.out_dir, a.count, a.seed, a.duration)
    except OSError as e:  # an output path that is a file, a folder that cannot be written
        print(f"error: cannot write {a.out_dir}: {e.strerror or e}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
