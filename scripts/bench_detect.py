"""Detection + tracking benchmark on the real Pose2Sim demo: full-frame vs ROI, side by side.

    .venv/bin/python scripts/bench_detect.py [--frames 100] [--repeat 3] [--threads 2] [--json out.json]

Median milliseconds per four-view frame for detection + tracking (video decoding
excluded), the split into pre-processing, inference, decoding and tracking, and the
identity figures (subject id per view, the others' ids, keypoint coverage). With
``--repeat`` each mode runs several times and the run with the best median is kept
(other processes share the CPU). ``bench(...)`` is the function ``cavewalk bench`` calls.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from pipeline.tracking.benchmark import DetectBenchResult, format_results, run_detect_benchmark


def bench(frames: int = 100, repeat: int = 1, threads: int = 2, modes: tuple[str, ...] = ("full", "roi"),
          settings: Any = None) -> list[DetectBenchResult]:
    """Benchmark on the demo data (fetched like ``cavewalk data demo``); best of ``repeat`` per mode."""
    from app.core.config import get_settings
    from pipeline.demo_data import fetch_demo
    from pipeline.pose.detector import PoseDetector, PoseDetectorConfig
    from pipeline.pose.roi import RoiConfig, RoiScheduler
    from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig
    from pipeline.tracking.stage import DetectAndTrack

    s = settings or get_settings()
    demo = fetch_demo(s.paths.cache_dir)
    det_cfg = replace(PoseDetectorConfig.from_settings(s.pose, s.pose_model_path), threads=threads)
    detector = PoseDetector.load(det_cfg)
    track_cfg = OCSortConfig.from_settings(s.tracking)
    results = []
    for mode in modes:
        roi_cfg = replace(RoiConfig.from_settings(s.pose), enabled=mode == "roi")

        def make(cams: list[str], roi_cfg: RoiConfig = roi_cfg) -> DetectAndTrack:
            return DetectAndTrack(detector, MultiViewTracker(cams, track_cfg), RoiScheduler(roi_cfg))

        runs = [run_detect_benchmark(demo.videos, make, mode, frames) for _ in range(repeat)]
        results.append(min(runs, key=lambda r: r.median_ms))
    return results


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=1)
    ap.add_argument("--threads", type=int, default=2, help="onnxruntime intra-op threads")
    ap.add_argument("--modes", default="full,roi")
    ap.add_argument("--json", type=Path, help="write the results as JSON here")
    args = ap.parse_args()
    results = bench(args.frames, args.repeat, args.threads, tuple(args.modes.split(",")))
    print(f"detection + tracking, {results[0].views} views, {results[0].frames} frames, "
          f"{args.threads} onnxruntime threads, {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f} (best of {args.repeat})")
    print(format_results(results))
    if args.json:
        args.json.write_text(json.dumps([r.to_dict() for r in results], indent=2))


if __name__ == "__main__":
    main()
