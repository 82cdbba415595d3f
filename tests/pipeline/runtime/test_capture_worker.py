"""The capture worker in its own process: frames into the ring, only when the detector wants them."""

from __future__ import annotations

import multiprocessing as mp
import os
import time
from pathlib import Path

import psutil
import pytest

from pipeline.runtime.messages import WorkerEvent
from pipeline.runtime.shm import FrameRing
from pipeline.runtime.workers import CaptureSpec, capture_loop, worker_main
from tests.waiting import GENEROUS_S, wait_until

pytestmark = pytest.mark.slow


def test_capture_publishes_only_what_is_demanded_then_ends(small_videos: dict[str, Path]) -> None:
    """The worker skips the frames nobody wants, writes those the detector wants, ends with the clip.

    The clip plays from when the worker opens it, by the worker's own clock; so the test waits
    for that moment (the video among the worker's open files) and then hands the worker a demand
    time 1 s ahead, which the worker itself reaches. A test that slept 0.2 s after the
    worker started and then wanted frames at once raced the machine: on a busy one the worker had
    not opened the clip yet (nothing skipped), or the clip was over (nothing written) (issue 15 S3).
    """
    ctx = mp.get_context("forkserver")
    ring = FrameRing.create(3, 300 * 500 * 3, "capt")  # the clips are 272 x 480
    events = ctx.Queue()
    stop = ctx.Event()
    ring.set_demand(time.monotonic() + 600.0)  # the detector will not look for a long while
    video = os.path.realpath(small_videos["cam01"])
    spec = CaptureSpec("cam01", video, pace_fps=10.0, loop=False)  # 60 frames: 6 s once it is open
    proc = ctx.Process(target=worker_main, args=("capture-cam01", capture_loop, events, stop, os.getpid(),
                                                  spec, ring.spec))
    proc.start()
    try:
        got: list[WorkerEvent] = []
        while not got or got[-1].kind != "started":
            got.append(events.get(timeout=GENEROUS_S))

        def opened() -> bool:
            return any(os.path.realpath(f.path) == video for f in psutil.Process(proc.pid).open_files())

        wait_until(opened, "the worker to open the clip", poll_s=0.02)
        assert ring.latest_seq == -1, "no frame is converted or copied before the detector wants one"
        ring.set_demand(time.monotonic() + 1.0)  # the detector looks again in 1 s, and from then on
        proc.join(GENEROUS_S)
        assert proc.exitcode == 0, "a video played once ends the worker cleanly"
        while got[-1].kind != "stopped":
            got.append(events.get(timeout=GENEROUS_S))
        kinds = [e.kind for e in got]
        assert "ended" in kinds and kinds[-1] == "stopped", kinds
        frame = ring.read_latest()
        assert frame is not None and frame.index == 59, "the clip's last frame is the newest"
        assert frame.seq < 59, "the frames skipped while nobody wanted them were never written"
    finally:
        stop.set()
        proc.join(timeout=10)
        if proc.is_alive():
            proc.kill()
        ring.unlink()
