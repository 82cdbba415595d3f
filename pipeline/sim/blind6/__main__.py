import argparse
import sys

from pipeline.errors import InputError
from pipeline.sim.blind6 import validate_args, write_set


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        print(f"error: {message}", file=sys.stderr)
        sys.exit(2)


def main(argv=None):
    ap = _Parser(prog="python -m pipeline.sim.blind6", description="write a set of blind6 sequences")
    ap.add_argument("out_dir")
    ap.add_argument("--count", default="12")
    ap.add_argument("--seed", default="60606")
    ap.add_argument("--duration", default="60")
    a = ap.parse_args(argv)
    try:
        try:
            count = int(a.count)
        except ValueError:
            raise InputError(f"count must be an integer in 1..1000, got {a.count!r}") from None
        try:
            seed = int(a.seed)
        except ValueError:
            raise InputError(f"seed must be an integer >= 0, got {a.seed!r}") from None
        try:
            dur = float(a.duration)
        except ValueError:
            raise InputError(f"duration must be a finite number in 10..3600 s, got {a.duration!r}") from None
        validate_args(count, seed, dur)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    try:
        paths = write_set(a.out_dir, count, seed, dur)
    except OSError as e:
        print(f"error: cannot write {a.out_dir}: {e.strerror or e}", file=sys.stderr)
        return 2
    for p in paths:
        print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
