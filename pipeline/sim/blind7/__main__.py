"""python -m pipeline.sim.blind7 OUT_DIR [--count 12] [--seed 70707] [--duration 60]"""

import argparse
import sys
import time

from pipeline.errors import InputError
from pipeline.sim.blind7 import validate_args, write_set


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        print(f"error: {message}", file=sys.stderr)
        sys.exit(2)


def main(argv=None):
    ap = _Parser(prog="python -m pipeline.sim.blind7", description="Write a blind7 synthetic stepping set.")
    ap.add_argument("out_dir")
    ap.add_argument("--count", default="12")
    ap.add_argument("--seed", default="70707")
    ap.add_argument("--duration", default="60")
    a = ap.parse_args(argv)
    try:
        count = int(a.count)
    except ValueError:
        count = a.count
    try:
        seed = int(a.seed)
    except ValueError:
        seed = a.seed
    try:
        dur = float(a.duration)
    except ValueError:
        dur = a.duration
    try:
        validate_args(count, seed, dur)
    except InputError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    try:
        paths = write_set(a.out_dir, count=count, seed=seed, duration_s=dur)
    except OSError as e:  # an output path that is a file, a folder that cannot be written
        print(f"error: cannot write {a.out_dir}: {e.strerror or e}", file=sys.stderr)
        return 2
    print(f"wrote {len(paths)} files to {a.out_dir} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
