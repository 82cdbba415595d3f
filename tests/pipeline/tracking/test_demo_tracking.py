"""Detection + tracking on the whole real Pose2Sim demo (4 views x 100 frames), ROI mode:
the subject keeps one id in every view, the bystander another, keypoints nearly always found."""

from __future__ import annotations

from pathlib import Path

import pytest

from pipeline.demo_data import DemoData
from pipeline.pose.config import PoseConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.roi import RoiScheduler
from pipeline.tracking.benchmark import run_detect_benchmark
from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig
from pipeline.tracking.stage import DetectAndTrack


@pytest.mark.slow
def test_demo_ids_are_stable_and_keypoints_found(demo_data: DemoData, pose_model_path: Path) -> None:
    detector = PoseDetector.load(PoseConfig(threads=2, parallel=1), pose_model_path)

    def make(cams: list[str]) -> DetectAndTrack:
        return DetectAndTrack(detector, MultiViewTracker(cams, OCSortConfig()), RoiScheduler(PoseConfig()))

    result = run_detect_benchmark(demo_data.videos, make, "roi")
    assert result.frames == 100 and result.views == 4
    assert result.full_frames < 20, f"ROI mode ran {result.full_frames} full-frame passes"
    bystander_views = 0
    for f in result.figures:
        assert list(f.subject_ids) == [1], f"{f.camera}: the subject had ids {f.subject_ids}"
        assert f.subject_ids[1] == 100, f"{f.camera}: subject reported in {f.subject_ids[1]}/100 frames"
        if f.other_ids:
            bystander_views += 1
            assert len(f.other_ids) == 1, f"{f.camera}: the bystander had ids {f.other_ids}"
            assert 1 not in f.other_ids and min(f.other_ids.values()) >= 95, f"{f.camera}: {f.other_ids}"
    assert bystander_views >= 1, "the bystander is visible in some views"
    assert result.keypoint_coverage >= 0.95, f"subject keypoints in {100 * result.keypoint_coverage:.1f}%"
