#!/usr/bin/env python
"""Soak test of the live pipeline: run it for a long time and watch memory.

    .venv/bin/python scripts/soak.py --duration 3600 --json soak.json
    .venv/bin/python scripts/soak.py --duration 300          # shortened
    .venv/bin/python scripts/soak.py --source demo --duration 900   # the real videos, live detection

``--source sim`` (default) runs the simulator at ``--fps``; ``--source demo`` the four
real demo videos, looping, paced at 30 fps, through capture, pose detection (ROI) and fusion.

Samples the resident memory (main process + workers, MB) every ``--every`` seconds,
fits a line to the samples after the warm-up and reports the growth over the run and
the slope in MB per hour. Passes (exit 0) when the growth stays under ``--max-growth-mb``
(default 50 MB) and the pipeline kept running; exit 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import logging
import signal
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--duration", type=float, default=3600.0, help="seconds to run (default 3600)")
    parser.add_argument("--source", choices=("sim", "demo"), default="sim")
    parser.add_argument("--fps", type=float, default=None,
                        help="simulator rate (default 60) or the videos' pace (default 30)")
    parser.add_argument("--every", type=float, default=5.0, help="seconds between memory samples")
    parser.add_argument("--warmup", type=float, default=20.0, help="seconds ignored at the start")
    parser.add_argument("--max-growth-mb", type=float, default=50.0)
    parser.add_argument("--json", type=Path, default=None, help="write the samples and figures here")
    args = parser.parse_args(argv)
    if args.duration <= args.warmup or args.every <= 0:
        parser.error("--duration must exceed --warmup, and --every must be > 0")
    if args.fps is not None and args.fps <= 0:
        parser.error(f"--fps must be > 0, got {args.fps}")

    from app.core.config import load_settings
    from app.core.logging import configure_logging
    from app.services.pipeline_factory import build_pipeline, simulator_factory
    from pipeline.runtime.bench import ProcessSampler

    configure_logging(logging.WARNING)
    signal.signal(signal.SIGTERM, signal.default_int_handler)
    settings = load_settings()
    base = settings.runtime
    videos = None
    if args.source == "demo":
        from pipeline.calibration.io import load_calibration
        from pipeline.demo_data import fetch_demo

        fps = args.fps or 30.0
        demo = fetch_demo(settings.paths.cache_dir, progress=lambda m: print(m, file=sys.stderr))
        config = replace(base, video_pace_fps=fps, video_loop=True, target_fps=fps)
        pipeline = build_pipeline(settings, load_calibration(demo.calibration), runtime=config)
        videos = dict(demo.videos)
    else:
        fps = args.fps or 60.0
        sim = simulator_factory(settings, replace(settings.sim, fps=fps))
        pipeline = build_pipeline(settings, None, sim, runtime=replace(base, target_fps=fps))
    pipeline.set_workstations([("127.0.0.1", 9)])  # the discard port: the stream is built and sent
    sampler = ProcessSampler()
    times: list[float] = []
    rss: list[float] = []
    start = time.monotonic()
    state_ok = True
    try:
        pipeline.start("videos" if videos else "simulator", videos)
        next_sample = start
        while (now := time.monotonic()) - start < args.duration:
            time.sleep(max(0.0, min(1.0, next_sample - now)))
            if time.monotonic() >= next_sample:
                sampler.sample()
                st = pipeline.status()
                times.append(time.monotonic() - start)
                rss.append(sampler.rss_samples_mb[-1])
                state_ok = state_ok and (st.state == "running" or times[-1] < args.warmup)
                print(f"{times[-1]:7.0f} s  rss {rss[-1]:7.1f} MB  {st.state:<8} {st.fps:5.1f} fps  "
                      f"processed {st.processed}  e2e p95 {st.latency_ms['end_to_end']['p95']:.1f} ms",
                      flush=True)
                next_sample += args.every
    except KeyboardInterrupt:
        print("interrupted: reporting what was measured", file=sys.stderr)
    finally:
        final = pipeline.status()
        pipeline.close()
    t = np.asarray(times)
    m = np.asarray(rss)
    keep = t >= args.warmup
    if keep.sum() < 3:
        print("too few samples after the warm-up", file=sys.stderr)
        return 1
    slope_mb_s, _ = np.polyfit(t[keep], m[keep], 1)
    growth = float(m[keep][-1] - m[keep][0])
    report = {
        "source": args.source,
        "fps": fps,
        "duration_s": round(float(t[-1]), 1),
        "samples": len(t),
        "rss_mb_first": round(float(m[keep][0]), 1),
        "rss_mb_last": round(float(m[keep][-1]), 1),
        "growth_mb": round(growth, 2),
        "slope_mb_per_hour": round(float(slope_mb_s) * 3600.0, 2),
        "processed": final.processed,
        "dropped": final.dropped,
        "state_ok": state_ok,
        "max_growth_mb": args.max_growth_mb,
        "series": {"t_s": [round(float(v), 1) for v in t], "rss_mb": [round(float(v), 1) for v in m]},
    }
    # over a short run the slope is mostly the warm-up of caches and windows; extrapolate it to
    # an hour only when the run lasted at least ten minutes
    hour_growth = slope_mb_s * 3600.0 if t[-1] >= 600.0 else 0.0
    ok = state_ok and growth < args.max_growth_mb and hour_growth < args.max_growth_mb
    print(json.dumps({k: v for k, v in report.items() if k != "series"}, indent=1))
    print("PASS" if ok else "FAIL", "(the growth, and for runs of 10 min or more the slope extrapolated "
          f"to one hour, must stay under {args.max_growth_mb:.0f} MB)")
    if args.json is not None:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(report, indent=1))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
