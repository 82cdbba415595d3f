"""The head pose geometry: the template fit recovers a posed head, with priors for a hidden face,
and the simulator's heads are exactly the template's frame (the ground truth of eval_head.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from pipeline.head.config import HeadConfig
from pipeline.head.pose import (
    EYE_CENTRE_M,
    FACE_JOINTS,
    FACE_TEMPLATE_M,
    HeadFrame,
    angle_deg,
    direction_angle_deg,
    head_pose_from_joints,
)
from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.skeleton import NUM_JOINTS, J


def posed_head(rot: np.ndarray, eye_m: np.ndarray, scale: float = 1.0) -> np.ndarray:
    """(17, 3) joints: only the face (the template at ``rot``, eyes' midpoint at ``eye_m``) and
    level shoulders below it, NaN elsewhere."""
    joints = np.full((NUM_JOINTS, 3), np.nan)
    t = eye_m - scale * rot @ EYE_CENTRE_M
    joints[list(FACE_JOINTS)] = scale * FACE_TEMPLATE_M @ rot.T + t
    right = rot[:, 0] * np.array([1.0, 1.0, 0.0])
    right /= np.linalg.norm(right)
    joints[J["l_shoulder"]] = t + np.array([0.0, 0.0, -0.25]) - 0.19 * right
    joints[J["r_shoulder"]] = t + np.array([0.0, 0.0, -0.25]) + 0.19 * right
    return joints


rotations = st.builds(
    lambda yaw, pitch, roll: Rotation.from_euler("ZXY", [yaw, pitch, roll], degrees=True).as_matrix(),
    st.floats(-180, 180),
    st.floats(-60, 60),
    st.floats(-40, 40),
)


@settings(max_examples=60, deadline=None)
@given(rot=rotations, x=st.floats(-1.5, 1.5), y=st.floats(-1.5, 1.5), z=st.floats(1.0, 2.0))
def test_the_fit_recovers_a_posed_head(rot: np.ndarray, x: float, y: float, z: float) -> None:
    eye = np.array([x, y, z])
    hf = head_pose_from_joints(posed_head(rot, eye))
    assert hf is not None and hf.method == "face"
    assert np.linalg.norm(hf.position_m - eye) < 1e-9, "the position is the point between the eyes"
    assert angle_deg(hf.rotation, rot) < 1e-6
    assert abs(np.linalg.det(hf.rotation) - 1.0) < 1e-9, "a proper rotation, never a mirror"


@pytest.mark.parametrize(
    "hidden", [(), ("l_ear",), ("r_ear", "r_eye"), ("nose", "l_ear"), ("l_eye", "r_eye")]
)
def test_any_three_face_keypoints_give_the_pose(hidden: tuple[str, ...]) -> None:
    rot = Rotation.from_euler("ZX", [35.0, -20.0], degrees=True).as_matrix()
    joints = posed_head(rot, np.array([0.3, -0.2, 1.6]))
    for name in hidden:
        joints[J[name]] = np.nan
    hf = head_pose_from_joints(joints)
    assert hf is not None and hf.method == "face", hidden
    assert angle_deg(hf.rotation, rot) < 1e-6 and np.linalg.norm(hf.position_m - [0.3, -0.2, 1.6]) < 1e-9


def test_a_head_larger_than_the_template_is_fitted_with_its_scale() -> None:
    rot = Rotation.from_euler("Z", 80.0, degrees=True).as_matrix()
    joints = posed_head(rot, np.array([0.0, 0.0, 1.7]), scale=1.1)
    assert head_pose_from_joints(joints, scale=None).scale == pytest.approx(1.1)
    fixed = head_pose_from_joints(joints, scale=1.1)
    assert np.linalg.norm(fixed.position_m - [0.0, 0.0, 1.7]) < 1e-9 and fixed.residual_m < 1e-9
    unit = head_pose_from_joints(joints)  # the wrong size: the rotation still right, the eyes off by mm
    assert (
        angle_deg(unit.rotation, rot) < 1e-6 and 0.0005 < np.linalg.norm(unit.position_m - [0, 0, 1.7]) < 0.01
    )


def test_a_hidden_face_keeps_the_tracks_rotation_and_turns_with_two_keypoints() -> None:
    rot = Rotation.from_euler("Z", 30.0, degrees=True).as_matrix()
    joints = posed_head(rot, np.array([0.0, 0.0, 1.6]))
    for name in ("nose", "l_eye", "r_eye"):  # seen from behind: only the ears
        joints[J[name]] = np.nan
    prior = Rotation.from_euler("Z", 20.0, degrees=True).as_matrix()  # last frame: 10 degrees behind
    hf = head_pose_from_joints(joints, prior_rotation=prior)
    assert hf is not None and hf.method == "partial"
    assert angle_deg(hf.rotation, rot) < 1.0, "the ears' line turns the head to its new yaw"
    assert np.linalg.norm(hf.position_m - [0.0, 0.0, 1.6]) < 0.003
    joints[J["l_ear"]] = np.nan  # one ear: the rotation is the prior's, the position from the ear
    one = head_pose_from_joints(joints, prior_rotation=rot)
    assert one is not None and angle_deg(one.rotation, rot) < 0.5
    assert np.linalg.norm(one.position_m - [0.0, 0.0, 1.6]) < 0.003


def test_without_a_track_the_shoulders_give_a_level_yaw() -> None:
    rot = Rotation.from_euler("Z", -50.0, degrees=True).as_matrix()
    joints = posed_head(rot, np.array([0.5, 0.5, 1.6]))
    joints[[J["nose"], J["l_eye"], J["r_eye"], J["l_ear"]]] = np.nan
    hf = head_pose_from_joints(joints)
    assert hf is not None and hf.method == "shoulders"
    assert direction_angle_deg(hf.forward, rot[:, 1]) < 1.0
    joints[[J["l_shoulder"], J["r_shoulder"]]] = np.nan
    assert head_pose_from_joints(joints) is None, "one ear and nothing else: no pose"
    assert head_pose_from_joints(np.full((NUM_JOINTS, 3), np.nan)) is None


def test_a_mirrored_face_still_gives_a_proper_rotation() -> None:
    rot = np.eye(3)
    joints = posed_head(rot, np.array([0.0, 0.0, 1.6]))
    joints[list(FACE_JOINTS)] = joints[[J["nose"], J["r_eye"], J["l_eye"], J["r_ear"], J["l_ear"]]]
    hf = head_pose_from_joints(joints)
    assert hf is not None and abs(np.linalg.det(hf.rotation) - 1.0) < 1e-9


@pytest.mark.parametrize("yaw", [0.0, 90.0, -135.0])
def test_the_simulators_head_is_the_templates_frame(yaw: float) -> None:
    """Standing still facing ``yaw``, the simulated person's face fits the template exactly and
    looks where the person faces (the ground truth of scripts/eval_head.py)."""
    motion = simulate_user(
        MotionScript((Segment("still", 1.0),), start_yaw_deg=yaw), body_from_height(1.8), fps=30.0, seed=3
    )
    for joints in motion.joints_m[::10]:
        hf = head_pose_from_joints(joints, scale=None)
        assert hf is not None and hf.residual_m < 1e-4
        facing = np.array([-math.sin(math.radians(yaw)), math.cos(math.radians(yaw)), 0.0])
        assert direction_angle_deg(hf.forward * [1, 1, 0], facing) < 15.0, "SPEC yaw: 0 faces +Y, CCW"
        assert hf.up[2] > 0.8


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"horizon_ms": -1.0}, "horizon_ms"),
        ({"display_ms": 600.0}, "display_ms"),
        ({"velocity_cutoff_hz": 0.0}, "velocity_cutoff_hz"),
        ({"angular_cutoff_hz": -1.0}, "angular_cutoff_hz"),
        ({"min_face_joints": 2}, "min_face_joints"),
        ({"reset_s": 0.0}, "reset_s"),
        ({"max_horizon_ms": 2000.0}, "max_horizon_ms"),
    ],
)
def test_bad_config_is_refused(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        HeadConfig(**kwargs)


def test_the_horizon_follows_the_measured_latency_unless_fixed() -> None:
    assert HeadConfig().horizon_s(0.080) == pytest.approx(0.080)
    assert HeadConfig(display_ms=20.0).horizon_s(0.080) == pytest.approx(0.100)
    assert HeadConfig(horizon_ms=30.0).horizon_s(0.080) == pytest.approx(0.030)
    assert HeadConfig(horizon_ms=0.0).horizon_s(0.080) == 0.0
    assert HeadConfig(max_horizon_ms=50.0).horizon_s(0.5) == pytest.approx(0.050)


def test_head_frame_checks_its_shapes() -> None:
    with pytest.raises(ValueError, match="rotation"):
        HeadFrame(np.zeros(3), np.eye(2))
    with pytest.raises(ValueError, match="method"):
        HeadFrame(np.zeros(3), np.eye(3), "guess")
