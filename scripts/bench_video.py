"""The CPU a take's camera videos cost: encoder CPU time per frame for the takes.video_* settings.

Decodes frames of one real demo view (Pose2Sim's, 1080x1920 I420, as the capture worker hands
them over), then encodes them through the real :class:`pipeline.takes.video.VideoWriter` for each
setting given, and reports the process CPU time per frame (user + system: what the encoder
thread takes from the machine, whatever the load; wall time is printed too but depends on the
load), the cores four cameras at 30 fps would need, and the MP4's megabytes per minute.

    python scripts/bench_video.py [--frames 90] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import av
import numpy as np

from app.core.config import get_settings
from pipeline.demo_data import fetch_demo
from pipeline.takes.video import VideoControl, VideoRequest, VideoWriter

SETTINGS: list[dict[str, Any]] = [
    {"preset": "ultrafast", "long_side": None},
    {"preset": "ultrafast", "long_side": 960},
    {"preset": "superfast", "long_side": None},
    {"preset": "veryfast", "long_side": None},
]


def frames_of(path: Path, n: int) -> list[np.ndarray]:
    with av.open(str(path)) as c:
        out = []
        for f in c.decode(video=0):
            out.append(np.ascontiguousarray(f.to_ndarray(format="yuv420p")))
            if len(out) == n:
                break
    return out


def encode(frames: list[np.ndarray], n: int, fps: float, folder: Path, **opts: Any) -> dict[str, float]:
    control = VideoControl.create(mp.get_context("forkserver"))
    gate = threading.Event()
    held = threading.Thread(target=gate.wait)  # every frame queued before the encoder starts
    held.start()
    path = folder / f"{opts['preset']}-{opts['long_side']}.mp4"
    req = VideoRequest(str(path), 0.0, fps=fps, queue_frames=n, **opts)
    writer = VideoWriter(req, "cam01", control, [0, 0, 0], after=held)
    for k in range(n):
        writer.offer(frames[k % len(frames)], k / fps, owned=True)
    writer.close()
    c0, w0 = time.process_time(), time.perf_counter()
    gate.set()
    writer.thread.join()
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    stats = control.stats()
    assert stats.written == n and stats.dropped == 0, stats
    per_frame_ms = 1000 * cpu / n
    return {"cpu_ms_per_frame": round(per_frame_ms, 2), "wall_ms_per_frame": round(1000 * wall / n, 2),
            "cores_for_4_cameras_at_30fps": round(4 * 30 * per_frame_ms / 1000, 2),
            "mb_per_minute_per_camera": round(path.stat().st_size / (n / fps) * 60 / 1e6, 1)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=90)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    demo = fetch_demo(get_settings().paths.cache_dir)
    frames = frames_of(demo.videos["cam01"], min(args.frames, 100))
    results: dict[str, dict[str, float]] = {}
    report: dict[str, Any] = {"load_avg_start": [round(v, 2) for v in os.getloadavg()],
                                 "cpus": os.cpu_count(), "frames": args.frames,
                                 "frame_size": [frames[0].shape[1], frames[0].shape[0] * 2 // 3],
                                 "av": av.__version__, "settings": results}
    with tempfile.TemporaryDirectory() as tmp:
        for opts in SETTINGS:
            name = f"{opts['preset']}, long side {opts['long_side'] or 'as captured'}"
            got = encode(frames, args.frames, 30.0, Path(tmp), **opts)
            results[name] = got
            print(f"{name:<36} {got['cpu_ms_per_frame']:6.2f} ms CPU/frame ({got['wall_ms_per_frame']:.2f} "
                  f"ms wall), {got['cores_for_4_cameras_at_30fps']:.2f} cores for 4 cameras at 30 fps, "
                  f"{got['mb_per_minute_per_camera']} MB/min per camera", flush=True)
    report["load_avg_end"] = [round(v, 2) for v in os.getloadavg()]
    print(f"load {report['load_avg_start']} at the start, {report['load_avg_end']} at the end, "
          f"{report['cpus']} CPUs")
    if args.json:
        args.json.write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
