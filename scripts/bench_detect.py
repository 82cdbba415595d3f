"""Detection + tracking benchmark on the real Pose2Sim demo: full-frame vs ROI, side by side.

    .venv/bin/python scripts/bench_detect.py [--frames 100] [--repeat 3] [--threads N] [--parallel N]
        [--precision fp32|int8|both] [--views-per-frame N] [--json out.json]

Median milliseconds per four-view frame for detection + tracking (video decoding
excluded), the split into pre-processing, inference, decoding and tracking, and the
identity figures (subject id per view, the others' ids, keypoint coverage). With
``--repeat`` each mode runs several times and the run with the best median is kept
(other processes share the CPU). ``cavewalk bench --stage detect`` can call
``pipeline.tracking.benchmark.bench_demo`` the same way ``bench()`` here does.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pipeline.tracking.benchmark import DetectBenchResult, bench_demo, format_results


def bench(frames: int = 100, repeat: int = 1, threads: int | None = None,
          modes: tuple[str, ...] = ("full", "roi"), spinning: bool = False,
          precision: str | None = None, parallel: int | None = None,
          views_per_frame: int | None = None) -> list[DetectBenchResult]:
    """The benchmark with the effective settings (the same call ``cavewalk bench`` makes);
    ``precision`` ("fp32" or "int8") overrides ``pose.precision``."""
    from app.core.config import get_settings

    s = get_settings()
    if precision is not None:
        s = s.model_copy(update={"pose": replace(s.pose, precision=precision)})
    return bench_demo(s.pose, s.tracking, s.pose_model_path, s.paths.cache_dir,
                      frames, repeat, threads, modes, spinning, parallel, views_per_frame)


def _count(text: str) -> int:
    """An integer >= 0 for argparse (0 = the automatic choice)."""
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {value}")
    return value


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--threads", type=_count, help="onnxruntime threads per call (default: pose.threads)")
    ap.add_argument("--parallel", type=_count, help="model calls side by side (default: pose.parallel)")
    ap.add_argument("--modes", default="full,roi")
    ap.add_argument("--views-per-frame", type=_count,
                    help="the model looks at most at this many views per frame, the others carry their "
                         "people (default: pose.views_per_frame; offline the adaptive 0 detects all)")
    ap.add_argument("--spinning", action="store_true", help="let onnxruntime threads spin-wait")
    ap.add_argument("--precision", choices=("fp32", "int8", "both"),
                    help="pose model file (default: the pose.precision setting)")
    ap.add_argument("--json", type=Path, help="write the results as JSON here")
    args = ap.parse_args()
    from pipeline.machine import machine_facts

    print(f"machine: {machine_facts().summary()}")
    precisions = ["fp32", "int8"] if args.precision == "both" else [args.precision]
    out = []
    for precision in precisions:
        results = bench(args.frames, args.repeat, args.threads, tuple(args.modes.split(",")),
                        args.spinning, precision, args.parallel, args.views_per_frame)
        print(f"detection + tracking, {results[0].views} views, {results[0].frames} frames, "
              f"model {precision or 'from the settings'}, "
              f"threads {args.threads or 'as set'}, parallel {args.parallel or 'as set'}, "
              f"views per frame {args.views_per_frame or 'as set'}"
              f"{' (spinning)' if args.spinning else ''}, "
              f"{os.cpu_count()} CPUs, load average "
              f"{os.getloadavg()[0]:.1f} (best of {args.repeat})")
        print(format_results(results))
        out += [{"precision": precision, **r.to_dict()} for r in results]
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
