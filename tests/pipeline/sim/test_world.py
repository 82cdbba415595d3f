"""The simulated world: navigator + bystanders stepping through time, seen by virtual cameras."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.camera import project
from pipeline.cave import box_cave
from pipeline.errors import InputError
from pipeline.sim.motion import MotionScript, Segment
from pipeline.sim.views import FaultConfig
from pipeline.sim.world import NAVIGATOR, SimConfig, SimWorld

SCRIPT = MotionScript(
    (Segment("still", 1.0), Segment("forward", 2.0), Segment("turn", 1.0, turn_deg=90), Segment("right", 1.0))
)


def test_navigator_follows_the_script_with_ground_truth() -> None:
    world = SimWorld.build(box_cave(), SimConfig(bystanders=1, seed=2), SCRIPT)
    assert world.people == (NAVIGATOR, "bystander1")
    frames = list(world.run(150))
    assert [f.frame_index for f in frames] == list(range(150))
    assert np.allclose([f.timestamp_s for f in frames], np.arange(150) / 30.0)
    labels = [f.label for f in frames]
    assert labels == ["still"] * 30 + ["forward"] * 60 + ["still"] * 30 + ["right"] * 30
    assert frames[0].yaw_deg == pytest.approx(0.0) and frames[-1].yaw_deg == pytest.approx(90.0)
    assert all(f.speed_mps > 0 for f in frames[30:90]) and all(f.speed_mps == 0 for f in frames[:30])
    for f in frames:
        assert [name for name, _ in f.truth] == [NAVIGATOR, "bystander1"]
        assert len(f.views) == 4 and len(f.view_people) == 4


def test_detections_belong_to_the_person_they_are_labelled_with() -> None:
    world = SimWorld.build(
        box_cave(), SimConfig(bystanders=2, seed=4, faults=FaultConfig(false_detection_rate=0.2))
    )
    cams = {c.name: c for c in world.cameras}
    checked = 0
    for f in world.run(20):
        for view, ids in zip(f.views, f.view_people, strict=True):
            for k, person in enumerate(ids.tolist()):
                if person < 0:
                    continue
                truth = project(cams[view.camera], f.truth[person][1])
                good = view.keypoint_scores[k] > 0.6
                err = np.linalg.norm(view.keypoints_xy[k][good] - truth[good], axis=1)
                assert err.size == 0 or np.median(err) < 15.0, "a detection is labelled with the wrong person"
                checked += 1
    assert checked > 100


def test_same_seed_same_world_other_seed_other_world() -> None:
    def run(seed: int) -> tuple[np.ndarray, np.ndarray]:
        frames = list(SimWorld.build(box_cave(), SimConfig(bystanders=1, seed=seed)).run(40))
        joints = np.array([[j for _, j in f.truth] for f in frames])
        kps = np.concatenate([v.keypoints_xy.ravel() for f in frames for v in f.views])
        return joints, kps

    a, b, c = run(5), run(5), run(6)
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1])
    assert not np.allclose(a[0], c[0])


@pytest.mark.slow
def test_long_runs_are_continuous_bystanders_walk_and_the_navigator_stays_central() -> None:
    cave = box_cave()
    world = SimWorld.build(
        cave,
        SimConfig(bystanders=2, seed=1, chunk_s=3.0, fps=15.0, camera_count=1, faults=FaultConfig.perfect()),
    )
    frames = list(world.run(15 * 40))
    joints = np.array([[j for _, j in f.truth] for f in frames])  # (T, people, 17, 3)
    jump = np.linalg.norm(np.diff(joints, axis=0), axis=-1).max()
    assert jump < 0.4, f"a joint jumped {jump:.2f} m in one frame (chunk joins must be smooth)"
    hips = joints[:, :, 11:13, :2].mean(axis=2)
    travelled = np.linalg.norm(np.diff(hips, axis=0), axis=-1).sum(axis=0)
    assert travelled[1] > 2.0 and travelled[2] > 2.0, f"bystanders did not walk around: {travelled}"
    half = np.array(cave.floor_half_size_m)
    assert np.all(np.abs(hips[:, 1:]) < half), "a bystander left the CAVE floor"
    assert np.linalg.norm(hips[:, 0], axis=-1).max() < 1.3, "the navigator wandered off the centre"
    assert {f.label for f in frames} == {"still", "forward", "left", "right"}


def test_realtime_run_stamps_frames_on_the_monotonic_clock() -> None:
    world = SimWorld.build(box_cave(), SimConfig(bystanders=0, fps=100.0))
    frames = list(world.run(5, realtime=True))
    stamps = np.array([f.timestamp_s for f in frames])
    assert np.allclose(np.diff(stamps), 0.01)
    assert [f.frame_index for f in frames] == [0, 1, 2, 3, 4]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"fps": 0.0}, "fps"),
        ({"bystanders": 9}, "bystanders"),
        ({"camera_preset": "gopro"}, "unknown camera preset"),
        ({"chunk_s": 1.0}, "chunk_s"),
        ({"navigator_height_m": 3.0}, "navigator_height_m"),
    ],
)
def test_bad_sim_configs_are_rejected(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        SimConfig(**kwargs)  # type: ignore[arg-type]


def test_chunks_join_on_the_feet_the_last_one_ended_on() -> None:
    world = SimWorld.build(box_cave(), SimConfig(bystanders=1, seed=1, chunk_s=3.0, fps=30.0, observe=False))
    frames = list(world.run(30 * 30))
    joints = np.array([f.navigator_joints for f in frames])
    contacts = np.array([f.contacts for f in frames])
    tags = np.array([f.tag for f in frames])
    step = np.linalg.norm(np.diff(joints[:, [15, 16], :2], axis=0), axis=-1)
    planted = np.where(contacts[1:] & contacts[:-1], step, 0.0)
    gliding = np.isin(tags[1:], ["turn", "march"]) | np.isin(tags[:-1], ["turn", "march"])
    assert planted[~gliding].max() < 1e-6, "a planted foot slid across a chunk join"
    assert {f.label for f in frames} >= {"still", "forward"}
