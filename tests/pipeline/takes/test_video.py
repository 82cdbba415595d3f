"""Camera videos of a take without the pipeline: the control shared with a worker, the tap and the
encoder thread writing real MP4s (read back with PyAV), drops counted when the encoder is behind."""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import av
import numpy as np
import pytest

from pipeline.takes.config import TakesConfig
from pipeline.takes.video import VideoControl, VideoRequest, VideoSession, VideoTap, VideoWriter

W, H = 320, 240
ROOT = Path(__file__).resolve().parents[3]


def i420(k: int) -> np.ndarray:
    """A (H * 3/2, W) I420 frame whose brightness encodes ``k``."""
    img = np.full((H * 3 // 2, W), 128, np.uint8)
    img[:H] = 16 + 8 * (k % 25)
    return img


def read_back(path: Path) -> tuple[list[float], tuple[int, int], list[float]]:
    with av.open(str(path)) as c:
        frames = list(c.decode(video=0))
        return (
            [float(f.time) for f in frames],
            (frames[0].width, frames[0].height),
            [float(f.to_ndarray(format="yuv420p")[: f.height].mean()) for f in frames],
        )


@contextlib.contextmanager
def capture_loop(tap: VideoTap) -> Iterator[None]:
    """What the capture worker does between frames: look at the control."""
    done = threading.Event()

    def poll() -> None:
        while not done.is_set():
            tap.active()
            time.sleep(0.005)

    t = threading.Thread(target=poll, daemon=True)
    t.start()
    try:
        yield
    finally:
        done.set()
        t.join(10)


@pytest.fixture()
def control() -> VideoControl:
    return VideoControl.create(mp.get_context("forkserver"))


def test_a_take_video_holds_the_frames_of_the_take_at_their_times(
    control: VideoControl, tmp_path: Path
) -> None:
    session = VideoSession({"cam01": (control, 20.0)}, tmp_path / "videos")
    tap = VideoTap(control, "cam01")
    assert not tap.active() and control.stats().state == "idle"
    t0 = 1000.0
    session.start(t0, duration_s=1.0)
    assert tap.active() and control.stats().state == "recording"
    times = [t0 - 0.1, *(t0 + k / 20 for k in range(25))]  # one before the take, five after its end
    for k, ts in enumerate(times):
        tap.offer(i420(k), ts)
        time.sleep(0.01)  # a camera's pace: the encoder keeps up
    with capture_loop(tap):
        got = session.stop(timeout_s=60)["cam01"]
    assert tap.active() is False, "the stop reached the tap"
    assert got["state"] == "closed" and got["written"] == 20 and got["dropped"] == 0, got
    pts, size, light = read_back(tmp_path / "videos" / "cam01.mp4")
    assert size == (W, H)
    np.testing.assert_allclose(pts, [k / 20 for k in range(20)], atol=1e-3, err_msg="the take's clock")
    assert abs(light[0] - (16 + 8)) < 6 and abs(light[5] - (16 + 8 * 6)) < 6, "the first frame is the take's"


def test_a_frame_just_before_the_takes_end_is_stamped_inside_it(
    control: VideoControl, tmp_path: Path
) -> None:
    """A frame 0.4 ms before the end of a 3 s take is written at 2.999 s, not at 3.000 (rounded to
    the millisecond it fell on the end, outside the take; a slow host's CI met it)."""
    counts = [0, 0, 0]
    req = VideoRequest(str(tmp_path / "cam.mp4"), t0_s=0.0, duration_s=3.0, fps=10.0)
    writer = VideoWriter(req, "cam", control, counts)
    for k, t in enumerate((0.0, 1.0, 2.9996, 3.0)):  # the last is after the take: skipped
        writer.offer(i420(k), t, owned=True)
    writer.close()
    writer.thread.join(30)
    pts, _, _ = read_back(tmp_path / "cam.mp4")
    assert len(pts) == 3 and all(0 <= t < 3.0 for t in pts), pts
    assert pts[-1] == pytest.approx(2.999, abs=1e-6)


def test_frames_the_encoder_cannot_take_are_dropped_oldest_first_and_counted(
    control: VideoControl, tmp_path: Path
) -> None:
    gate = threading.Event()
    busy = threading.Thread(target=gate.wait)  # the encoder is busy with a previous file
    busy.start()
    counts = [0, 0, 0]
    req = VideoRequest(str(tmp_path / "cam.mp4"), t0_s=0.0, fps=10.0, queue_frames=3)
    writer = VideoWriter(req, "cam", control, counts, after=busy)
    start = time.monotonic()
    for k in range(10):
        writer.offer(i420(k), 0.1 * k, owned=True)
    assert time.monotonic() - start < 5, "offering never waits for the encoder"  # generous: 10 appends
    gate.set()
    writer.close()
    writer.thread.join(30)
    stats = control.stats()
    assert (stats.written, stats.dropped, stats.state) == (3, 7, "closed"), stats
    pts, _, light = read_back(tmp_path / "cam.mp4")
    np.testing.assert_allclose(pts, [0.7, 0.8, 0.9], atol=1e-3)  # the newest three were kept
    assert abs(light[0] - (16 + 8 * 7)) < 6


def test_bgr_frames_are_scaled_to_the_long_side_and_a_restarted_worker_writes_a_second_file(
    control: VideoControl, tmp_path: Path
) -> None:
    config = TakesConfig(video_long_side=160)
    session = VideoSession({"cam": (control, 10.0)}, tmp_path, config)
    session.start(0.0)
    first = VideoTap(control, "cam")
    assert first.active()
    bgr = np.zeros((H, W, 3), np.uint8)
    first.offer(bgr, 0.0)
    first.close()  # the worker died mid-take; a new one sees the same request
    second = VideoTap(control, "cam")
    assert second.active()
    second.offer(bgr, 0.5)
    with capture_loop(second):
        got = session.stop(timeout_s=60)["cam"]
    assert second.active() is False and got["state"] == "closed" and got["files"] == 1, got
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cam-2.mp4", "cam.mp4"]
    assert read_back(tmp_path / "cam.mp4")[1] == (160, 120)


def test_a_video_that_cannot_be_written_is_an_error_the_capture_goes_on(
    control: VideoControl, tmp_path: Path
) -> None:
    (tmp_path / "file").write_text("not a folder")
    session = VideoSession({"cam": (control, 10.0)}, tmp_path / "file" / "videos")
    tap = VideoTap(control, "cam")
    session.start(0.0)
    assert tap.active()
    tap.offer(i420(0), 0.1)  # returns at once; the writer thread finds it cannot write
    with capture_loop(tap):
        got = session.stop(timeout_s=60)["cam"]
    assert got["state"] == "error" and "writing the video failed" in (got["error"] or ""), got
    tap.offer(i420(1), 0.2)  # the tap has stopped: nothing happens


def test_no_cameras_no_videos() -> None:
    with pytest.raises(ValueError, match="the simulator has no images"):
        VideoSession({}, Path("videos"))


CRASH = """
import os, sys, time, multiprocessing as mp
import numpy as np
from pipeline.takes.video import VideoControl, VideoRequest, VideoWriter
control = VideoControl.create(mp.get_context("forkserver"))
counts = [0, 0, 0]
w = VideoWriter(VideoRequest(sys.argv[1], 10.0, fps=10.0, queue_frames=100), "cam", control, counts)
for k in range(35):  # 3.5 s at 10 fps from 0.2 s into the take: key frames (fragments) every second
    w.offer(np.full((240 * 3 // 2, 320), 16 + 5 * k, np.uint8), 10.2 + k / 10, owned=True)
while counts[0] < 35:
    time.sleep(0.01)
os._exit(9)  # killed: the file is never closed
"""


def test_a_crash_keeps_the_video_up_to_its_last_key_frame(tmp_path: Path) -> None:
    path = tmp_path / "cam.mp4"
    proc = subprocess.run(
        [sys.executable, "-c", CRASH, str(path)], cwd=ROOT, capture_output=True, timeout=120
    )
    assert proc.returncode == 9, proc.stderr.decode()[-2000:]
    pts, _, _ = read_back(path)
    assert 25 <= len(pts) <= 35, f"{len(pts)} of 35 frames survived (at most the last second is lost)"
    np.testing.assert_allclose(pts, [0.2 + k / 10 for k in range(len(pts))], atol=1e-3)
