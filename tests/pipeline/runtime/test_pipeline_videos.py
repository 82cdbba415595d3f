"""The live pipeline on real video (the Pose2Sim demo, scaled down) with the real pose model."""

from __future__ import annotations

import os
import shutil
from dataclasses import replace
from pathlib import Path
from typing import Any

import cv2
import pytest

from pipeline.demo_data import DemoData
from pipeline.errors import InputError, SourceError
from pipeline.pose.config import PoseConfig
from pipeline.runtime.chain import PoseModel
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.pipeline import Pipeline
from pipeline.runtime.shm import SHM_PREFIX
from pipeline.sources.grouper import GrouperConfig
from tests.waiting import wait_until

from .live import CreatedRings, children_alive, shm_segments, wait_for

pytestmark = pytest.mark.slow


def video_pipeline(pose_model_path: Path, cameras: dict[str, str] | None = None,
                   **config: object) -> Pipeline:
    base = RuntimeConfig(target_fps=15.0, video_pace_fps=15.0, video_loop=True, camera_retry_s=0.3,
                         grouper=GrouperConfig(tolerance_s=0.03, max_wait_s=0.02, gone_after_s=0.6))
    return Pipeline(replace(base, **config), None, camera_sources=cameras,  # type: ignore[arg-type]
                    pose=PoseModel(PoseConfig(), pose_model_path))


def test_videos_run_with_the_real_detector_and_stop_clean(
        pose_model_path: Path, small_videos: dict[str, Path], created_rings: CreatedRings) -> None:
    pipeline = video_pipeline(pose_model_path)
    try:
        pipeline.start("videos", {k: small_videos[k] for k in ("cam01", "cam02")})
        rings = set(created_rings.of(SHM_PREFIX))
        assert len(rings) == 2 and rings <= shm_segments(), "one shared-memory ring per camera"
        wait_for(lambda: pipeline.status().processed >= 5, 120, "5 processed multi-view frames")
        st = pipeline.status()
        assert st.state == "running" and st.source == "videos"
        assert st.latency_ms["detect"]["p50"] > 0
        latest = pipeline._run.latest  # type: ignore[union-attr]
        assert latest is not None
        people = [len(v) for v in latest.detected.views]
        assert sum(people) >= 1, f"the demo's person is detected in the real frames, got {people}"
        jpeg = pipeline.snapshot_jpeg("cam01")
        assert jpeg is not None and jpeg[:2] == b"\xff\xd8"
        pids = pipeline.worker_pids()
        assert len(pids) == 4, "two capture workers, detect, fuse"
    finally:
        pipeline.close()
    assert children_alive(pids) == []
    assert not created_rings.existing(), "every ring (and mailbox) is unlinked at stop"


def test_a_video_that_ends_and_a_camera_that_vanishes_do_not_stop_the_others(
        pose_model_path: Path, small_videos: dict[str, Path],
        tmp_path: Path) -> None:
    """cam03 (a 12-frame video, played once) ends, cam04 (an image folder) vanishes; cam01 goes on.

    The cameras that must go on are image folders of 1200 frames (hard links to 60 real frames:
    two minutes at 10 fps, free to make), so that they outlast the test however busy the machine
    is: with cam01 a 60-frame video played once (6 s), a loaded machine reached the last check
    after cam01 had ended too (issue 15 S3). The waits are for outcomes (tests/waiting.py)."""
    frames = tmp_path / "frames"
    frames.mkdir()
    cap = cv2.VideoCapture(str(small_videos["cam01"]))
    for i in range(60):
        ok, img = cap.read()
        assert ok
        cv2.imwrite(str(frames / f"{i:03d}.png"), img)
    cap.release()

    def long_folder(name: str, n: int = 1200) -> Path:
        folder = tmp_path / name
        folder.mkdir()
        for i in range(n):  # forwards and back, so that the motion stays continuous
            k = i % 120
            os.link(frames / f"{k if k < 60 else 119 - k:03d}.png", folder / f"{i:04d}.png")
        return folder

    cam04 = long_folder("cam04")
    cameras = {"cam01": str(long_folder("cam01")), "cam03": str(small_videos["cam03"]), "cam04": str(cam04)}
    # played once at 10 fps: cam03 (12 frames) ends after 1.2 s, cam01 and cam04 would last 120 s
    pipeline = video_pipeline(pose_model_path, cameras, video_loop=False, video_pace_fps=10.0)

    def health() -> dict[str, dict[str, Any]]:
        return {c.name: c.to_json() for c in pipeline.status().cameras}

    def camera(name: str) -> dict[str, Any]:
        return health().get(name, {})

    try:
        pipeline.start("cameras")
        wait_until(lambda: camera("cam03").get("last_error") == "source ended", "cam03 to end")
        wait_until(lambda: camera("cam04").get("ok"), "cam04 to deliver (it vanishes while it does)")
        shutil.rmtree(cam04)
        wait_until(lambda: camera("cam04").get("ok") is False, "cam04 reported lost")
        count = pipeline.status().processed
        wait_until(lambda: pipeline.status().processed >= count + 3, "cam01 frames processed meanwhile")
        st = pipeline.status()
        assert st.state == "running"
        cams = health()
        assert cams["cam01"]["ok"], cams
        assert not cams["cam03"]["ok"] and not cams["cam04"]["ok"]
        latest = pipeline._run.latest  # type: ignore[union-attr]
        assert latest is not None
        # neither gave an image to the newest frame: listed as missing, or (a detect group rebuilt
        # without them on a loaded machine) not among its views at all
        delivered = {v.camera for v in latest.detected.views} - set(latest.detected.missing)
        assert not delivered & {"cam03", "cam04"}, (delivered, latest.detected.missing)
        events = pipeline.drain_events()
        assert any(e.kind == "camera" and "cam04" in e.message and "camera_lost" in e.message for e in events)
        assert not any(e.kind == "worker" and "chain died" in e.message for e in events), "the chain goes on"
    finally:
        pipeline.close()


def test_bad_videos_are_rejected_and_nothing_starts(
        pose_model_path: Path, small_videos: dict[str, Path],
        tmp_path: Path, created_rings: CreatedRings) -> None:
    bad = tmp_path / "bad.mp4"
    bad.write_bytes(b"not a video")
    pipeline = video_pipeline(pose_model_path)
    try:
        with pytest.raises(InputError, match="video not found"):
            pipeline.start("videos", {"cam01": tmp_path / "missing.mp4"})
        with pytest.raises(SourceError, match="cannot open video"):
            pipeline.start("videos", {"cam01": small_videos["cam01"], "cam02": bad})
        with pytest.raises(SourceError, match="no camera has a real source"):
            pipeline.start("cameras")
        assert pipeline.status().state == "stopped"
        assert not created_rings.existing(), "a rejected start leaves no ring behind"
    finally:
        pipeline.close()


def test_calibration_that_does_not_match_the_videos(
        pose_model_path: Path, small_videos: dict[str, Path],
        demo_data: DemoData) -> None:
    from pipeline.calibration.io import load_calibration

    cams = load_calibration(demo_data.calibration)
    pipeline = Pipeline(RuntimeConfig(), cams, pose=PoseModel(PoseConfig(), pose_model_path))
    try:
        with pytest.raises(InputError, match=r"cameras \['side'\] are not in the calibration"):
            pipeline.start("videos", {"cam01": small_videos["cam01"], "side": small_videos["cam02"]})
        assert pipeline.status().state == "stopped"
    finally:
        pipeline.close()


def test_a_killed_capture_worker_is_restarted_and_its_camera_returns(
        pose_model_path: Path, small_videos: dict[str, Path]) -> None:
    import os
    import signal

    pipeline = video_pipeline(pose_model_path)
    try:
        pipeline.start("videos", {k: small_videos[k] for k in ("cam01", "cam02")})
        wait_for(lambda: pipeline.status().processed >= 2, 120, "first results")
        assert set(pipeline.workers()) == {"capture-cam01", "capture-cam02", "detect", "fuse"}
        victim = pipeline.workers()["capture-cam02"]
        os.kill(victim, signal.SIGKILL)
        wait_for(lambda: pipeline.workers().get("capture-cam02") not in (None, victim), 30,
                 "the capture worker to be restarted")
        wait_for(lambda: all(c.ok for c in pipeline.status().cameras), 30, "both cameras ok again")
        count = pipeline.status().processed
        wait_for(lambda: pipeline.status().processed >= count + 2, 60, "results after the restart")
        assert pipeline.status().state == "running"
        events = [e.message for e in pipeline.drain_events()]
        assert any("capture-cam02 died" in m for m in events), events
        assert any("capture-cam02 restarted" in m for m in events), events
    finally:
        pipeline.close()
