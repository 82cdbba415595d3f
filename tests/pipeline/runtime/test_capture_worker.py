"""The capture worker in its own process: frames into the ring, only when the detector wants them."""

from __future__ import annotations

import multiprocessing as mp
import os
import time
from pathlib import Path

import pytest

from pipeline.runtime.messages import WorkerEvent
from pipeline.runtime.shm import FrameRing
from pipeline.runtime.workers import CaptureSpec, capture_loop, worker_main

from .live import wait_for

pytestmark = pytest.mark.slow


def test_capture_publishes_only_what_is_demanded_then_ends(small_videos: dict[str, Path]) -> None:
    ctx = mp.get_context("forkserver")
    ring = FrameRing.create(3, 300 * 500 * 3, "capt")  # the clips are 272 x 480
    events = ctx.Queue()
    stop = ctx.Event()
    ring.set_demand(time.monotonic() + 600.0)  # the detector will not look for a long while
    spec = CaptureSpec("cam01", str(small_videos["cam01"]), pace_fps=20.0, loop=False)  # 60 frames: 3 s
    proc = ctx.Process(target=worker_main, args=("capture-cam01", capture_loop, events, stop, os.getpid(),
                                                  spec, ring.spec))
    proc.start()
    try:
        got: list[WorkerEvent] = []
        wait_for(lambda: got.append(events.get(timeout=5)) or got[-1].kind == "started", 60, "the worker")
        time.sleep(0.2)
        assert ring.latest_seq == -1, "no frame is converted or copied before the detector wants one"
        ring.set_demand(0.0)
        wait_for(lambda: ring.latest_seq >= 0, 10, "a frame once the detector wants them")
        proc.join(timeout=30)
        while not events.empty() or proc.exitcode is None:
            got.append(events.get(timeout=5))
            if got[-1].kind == "stopped":
                break
        kinds = [e.kind for e in got]
        assert "ended" in kinds and kinds[-1] == "stopped", kinds
        assert proc.exitcode == 0, "a video played once ends the worker cleanly"
        frame = ring.read_latest()
        assert frame is not None and frame.index == 59, "the clip's last frame is the newest"
        assert frame.seq < 59, "the frames skipped while nobody wanted them were never written"
    finally:
        stop.set()
        proc.join(timeout=10)
        if proc.is_alive():
            proc.kill()
        ring.unlink()
