"""HeadTracker: velocities, prediction, resets and the users it follows."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from pipeline.head.config import HeadConfig
from pipeline.head.pose import angle_deg
from pipeline.head.tracker import HeadPose, HeadTracker
from pipeline.triangulation.types import Person3D

from .test_pose import posed_head


def person(uid: int, rot: np.ndarray, eye: np.ndarray) -> Person3D:
    joints = posed_head(rot, eye)
    valid = np.all(np.isfinite(joints), axis=1)
    return Person3D(uid, np.where(valid[:, None], joints, 0.0), valid, 1.0)


def pose_rot(p: HeadPose) -> np.ndarray:
    return np.stack([np.cross(p.forward, p.up), p.forward, p.up], axis=1)


def test_a_head_moving_steadily_is_predicted_where_it_will_be() -> None:
    tracker = HeadTracker(HeadConfig(velocity_cutoff_hz=3.0))
    v = np.array([0.6, -0.3, 0.0])
    rot = Rotation.from_euler("Z", 40.0, degrees=True).as_matrix()
    for k in range(60):  # 2 s at 30 fps
        t = k / 30
        est = tracker.update([person(1, rot, np.array([0.0, 0.0, 1.6]) + v * t)], t)[0]
    assert np.allclose(est.velocity_mps, v, atol=1e-3), est.velocity_mps
    later = est.predict(0.1)
    assert later.predicted_ms == pytest.approx(100.0)
    assert np.linalg.norm(np.asarray(later.position_m) - (np.array([0, 0, 1.6]) + v * (t + 0.1))) < 1e-3
    measured = est.predict(0.0)
    assert measured.predicted_ms == 0.0
    assert np.linalg.norm(np.asarray(measured.position_m) - (np.array([0, 0, 1.6]) + v * t)) < 1e-9


def test_rotation_is_extrapolated_only_when_asked() -> None:
    spin = np.radians(90.0)  # 90 deg/s about +Z
    for cutoff, expect_deg in ((0.0, 9.0), (3.0, 0.0)):
        tracker = HeadTracker(HeadConfig(angular_cutoff_hz=cutoff))
        for k in range(60):
            t = k / 30
            rot = Rotation.from_euler("Z", spin * t).as_matrix()
            est = tracker.update([person(1, rot, np.array([0.0, 0.0, 1.6]))], t)[0]
        truth = Rotation.from_euler("Z", spin * (t + 0.1)).as_matrix()
        err = angle_deg(pose_rot(est.predict(0.1)), truth)
        assert err == pytest.approx(expect_deg, abs=0.3), (cutoff, err)


def test_a_gap_longer_than_reset_starts_afresh_and_only_wanted_users_are_followed() -> None:
    tracker = HeadTracker(HeadConfig(reset_s=0.5))
    rot = np.eye(3)
    for k in range(10):
        out = tracker.update(
            [person(1, rot, np.array([0.1 * k, 0.0, 1.6])), person(2, rot, np.ones(3))], k / 30, users=[1]
        )
        assert [e.user_id for e in out] == [1], "users= filters"
    assert np.linalg.norm(out[0].velocity_mps) > 1.0
    after = tracker.update([person(1, rot, np.array([5.0, 0.0, 1.6]))], 10 / 30 + 1.0)[0]
    assert np.allclose(after.velocity_mps, 0.0), "a new track after the gap: no jump into a velocity"
    assert tracker.update([], 5.0) == ()


def test_head_size_is_learned_from_full_faces() -> None:
    tracker = HeadTracker()
    rot = np.eye(3)
    joints = posed_head(rot, np.array([0.0, 0.0, 1.7]), scale=1.12)
    valid = np.all(np.isfinite(joints), axis=1)
    p = Person3D(4, np.where(valid[:, None], joints, 0.0), valid, 1.0)
    assert tracker.scale(4) == 1.0
    for k in range(12):
        est = tracker.update([p], k / 30)[0]
    assert tracker.scale(4) == pytest.approx(1.12)
    assert np.linalg.norm(est.position_m - [0.0, 0.0, 1.7]) < 1e-9


def test_head_pose_checks_its_fields() -> None:
    with pytest.raises(ValueError, match="forward"):
        HeadPose(1, (0.0, 0.0, 1.0), (0.0, 1.0), (0.0, 0.0, 1.0), 1.0)
    with pytest.raises(ValueError, match="predicted_ms"):
        HeadPose(1, (0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0), 1.0, -5.0)
