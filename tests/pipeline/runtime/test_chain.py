"""The one chain builder (issue 16 item 2): the simulator is a detector in front of the pose stage,
the pose stage tracks, fusion gets tracked views only; the config travels to the workers."""

from __future__ import annotations

import pickle
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from pipeline.cave import box_cave
from pipeline.errors import ModelError
from pipeline.pose.config import PoseConfig
from pipeline.pose.roi import RoiScheduler
from pipeline.recognition.recognizer import RecognizerConfig
from pipeline.results import FrameResult
from pipeline.runtime.chain import (
    ChainConfig,
    PoseModel,
    SimWorldFactory,
    build_chain,
    build_detector,
    build_fusion,
    build_pose_stage,
)
from pipeline.runtime.messages import DetectedFrame, TrackedFrame
from pipeline.runtime.stages import PoseStage, SimDetector
from pipeline.sim.world import SimConfig
from pipeline.tracking.ocsort import MultiViewTracker
from pipeline.tracking.stage import DetectAndTrack


def simulator(seed: int = 3) -> SimWorldFactory:
    return SimWorldFactory.build(SimConfig(fps=30.0, bystanders=1, seed=seed), box_cave())


def summary(result: FrameResult) -> tuple[object, ...]:
    """What a frame's result says, comparably: tracks per view, 3D people, navigator, action."""
    tracks = tuple((v.camera, tuple(v.track_ids.tolist())) for v in result.views)
    people = tuple((p.user_id, np.round(p.joints_m, 6).tobytes()) for p in result.people3d)
    action = None if result.action is None else (result.action.label, round(result.action.confidence, 6))
    return result.frame_index, tracks, people, result.navigator, action


def run_workers_halves(config: ChainConfig, frames: int) -> list[FrameResult]:
    """The chain as the live runtime runs it: the simulator worker's half (detector + pose stage)
    and the fuse worker's half (fusion), built from the config each worker receives (pickled)."""
    sent = pickle.loads(pickle.dumps(config))
    detector, pose = build_detector(sent), build_pose_stage(sent)
    fusion = build_fusion(pickle.loads(pickle.dumps(config)))
    out = []
    for i in range(frames):
        t = i / 30.0
        views = detector.detect(i, t)
        tracked = TrackedFrame(DetectedFrame(i, t, views, t, t), pose.track(views))
        out.append(fusion.update(tracked))
    return out


def test_the_live_halves_and_the_one_process_chain_give_the_same_results() -> None:
    sim = simulator()
    config = ChainConfig(recognition=RecognizerConfig()).on_simulator(sim)
    live = run_workers_halves(config, 90)
    chain = build_chain(config)
    world = sim()
    one = [chain.update(DetectedFrame(i, i / 30.0, tuple(world.step(timestamp_s=i / 30.0).views),
                                      i / 30.0, i / 30.0))
           for i in range(90)]
    assert [summary(r) for r in live] == [summary(r) for r in one]
    assert any(r.people3d for r in live) and any(r.navigator is not None for r in live), (
        "the simulated people are tracked, triangulated and one navigates")


def test_the_simulator_is_a_detector_and_the_pose_stage_tracks_its_views() -> None:
    config = ChainConfig().on_simulator(simulator())
    detector, pose = build_detector(config), build_pose_stage(config)
    assert isinstance(detector, SimDetector) and pose.model is None
    assert detector.cameras == pose.cameras == config.camera_names
    ids: set[int] = set()
    for i in range(20):
        views = detector.detect(i, i / 30.0)
        assert all(v.frame_index == i for v in views), "the detections carry the frame's index"
        tracked = pose.track(views)
        assert [t.camera for t in tracked] == list(config.camera_names)
        ids |= {int(x) for t in tracked for x in t.track_ids}
    assert ids, "the simulated people get track ids in the pose stage"


@pytest.mark.parametrize(("make", "error", "match"), [
    (lambda: build_detector(ChainConfig(camera_names=("cam01",),
                                        detector=PoseModel(PoseConfig(), Path("none.onnx")))),
     ValueError, "not the simulator"),
    (lambda: build_detector(ChainConfig(camera_names=("cam01",))), ValueError, "not the simulator"),
    (lambda: build_pose_stage(ChainConfig()), ValueError, "non-empty camera names"),
    (lambda: ChainConfig(camera_names=("cam01", "cam01")), ValueError, "must be distinct"),
    (lambda: ChainConfig(cameras=simulator().cameras, camera_names=("cam01", "cam02")), ValueError,
     r"calibrated cameras \['cam03', 'cam04'\] are not among the views"),
    (lambda: PoseStage(MultiViewTracker(["cam01"])).detect([], ["cam01"], 0, 0.0), ModelError,
     "no pose model"),
    (lambda: PoseStage(MultiViewTracker(["cam01"]),  # a model that tracks with a tracker of its own
                       DetectAndTrack(None, MultiViewTracker(["cam01"]), RoiScheduler(PoseConfig()))),  # type: ignore[arg-type]
     ValueError, "this stage's tracker"),
    (lambda: SimDetector(simulator()(), 0.0), ValueError, "fps must be > 0"),
    (lambda: SimWorldFactory(box_cave(), (), SimConfig(), 30.0), ValueError, "at least one camera"),
])
def test_what_cannot_be_built_says_why(make: object, error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        make()  # type: ignore[operator]


def test_tracked_views_must_be_the_detected_frames_views() -> None:
    config = ChainConfig().on_simulator(simulator())
    detector, pose = build_detector(config), build_pose_stage(config)
    views = detector.detect(0, 0.0)
    detected = DetectedFrame(0, 0.0, views, 0.0, 0.0)
    tracked = pose.track(views)
    assert TrackedFrame(detected, tracked).frame_index == 0
    with pytest.raises(ValueError, match="do not match the detected views"):
        TrackedFrame(detected, tracked[1:])
    with pytest.raises(ValueError, match="do not match the detected views"):
        TrackedFrame(detected, tuple(reversed(tracked)))


def test_a_missing_action_model_is_an_error_offline_and_a_warning_live(tmp_path: Path) -> None:
    config = replace(ChainConfig().on_simulator(simulator()),
                     recognition=RecognizerConfig(model_path=tmp_path / "gone.onnx"))
    with pytest.raises(ModelError, match="action model not found"):
        build_chain(config, need_actions=True)  # cavewalk process: one clear message
    fusion = build_fusion(config)  # the live fuse worker: 3D and the navigator without actions
    assert fusion.recognizer is None and fusion.reconstructor is not None and fusion.selector is not None
