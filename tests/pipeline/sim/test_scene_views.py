"""Virtual cameras: placement, projection, and the faults of the simulated pose detector."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.camera import Camera, intrinsics, look_at, project
from pipeline.cave import box_cave
from pipeline.errors import InputError
from pipeline.pose.types import ViewDetections
from pipeline.sim.motion import MotionScript, Segment, body_from_height, simulate_user
from pipeline.sim.scene import PRESETS, default_cameras
from pipeline.sim.views import FaultConfig, observe, observe_with_ids, visibility
from pipeline.skeleton import J


def _person(xy: tuple[float, float] = (0.0, 0.0), yaw: float = 0.0, height: float = 1.75) -> np.ndarray:
    m = simulate_user(
        MotionScript((Segment("still", 0.2, gestures=()),), start_xy_m=xy, start_yaw_deg=yaw),
        body_from_height(height),
        seed=0,
    )
    return m.joints_m[0]


def test_projection_matches_a_hand_computation() -> None:
    # camera 3 m behind the origin on -Y at 1 m height, looking along +Y:
    # x_cam = X, y_cam = 1 - Z, z_cam = Y + 3
    R, t = look_at(np.array([0.0, -3.0, 1.0]), np.array([0.0, 0.0, 1.0]))
    k1, k2 = 0.05, -0.02
    cam = Camera("c", (1000, 800), intrinsics(800.0, 810.0, 500.0, 400.0), np.array([k1, k2, 0, 0, 0]), R, t)
    point = np.array([0.5, 0.0, 1.5])
    x, y = 0.5 / 3.0, -0.5 / 3.0
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2
    expected = np.array([800.0 * x * radial + 500.0, 810.0 * y * radial + 400.0])
    assert np.allclose(project(cam, point), expected, atol=1e-9)
    views = observe(
        [cam],
        [np.tile(point, (17, 1))],
        0,
        0.0,
        np.random.default_rng(0),
        FaultConfig.perfect().replace(occlusion=False, min_box_height_px=0.0),
    )
    assert np.allclose(views[0].keypoints_xy[0], expected, atol=1e-3), (
        "the virtual camera must project exactly"
    )


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_a_preset_K_is_the_intrinsics_matrix_of_its_focal_length_and_image_centre(preset: str) -> None:
    p = PRESETS[preset]
    w, h = p.image_size
    expected = intrinsics(p.focal_px, p.focal_px, (w - 1) / 2.0, (h - 1) / 2.0)
    assert np.array_equal(p.K(), expected), "CameraPreset.K() must build what pipeline.camera.intrinsics does"


@pytest.mark.parametrize("preset", sorted(PRESETS))
def test_default_cameras_hang_above_each_wall_and_look_at_the_centre(preset: str) -> None:
    cave = box_cave(3.0, 3.0, 2.5)
    cams = default_cameras(cave, preset)
    assert [c.name for c in cams] == ["cam01", "cam02", "cam03", "cam04"]
    p = PRESETS[preset]
    for cam, wall in zip(cams, cave.walls, strict=True):
        assert cam.image_size == p.image_size
        assert cam.K[0, 0] == pytest.approx(p.focal_px)
        c = cam.center_m
        assert c[2] == pytest.approx(2.3)
        top_mid = wall.corners_m[:2].mean(axis=0)
        assert np.linalg.norm(c[:2] - top_mid[:2]) < 0.2, f"{cam.name} is not above the {wall.name} wall"
        centre_px = project(cam, np.array([0.0, 0.0, 1.0]))
        assert np.allclose(centre_px, (np.array(p.image_size) - 1) / 2, atol=1e-6)
    # a person standing in the middle is fully in view of every camera
    person = _person()
    for cam in cams:
        vis = visibility(cam, [person], 0)
        assert vis.in_image.all(), f"{preset} {cam.name} does not see the whole person"
    with pytest.raises(InputError, match="unknown camera preset"):
        default_cameras(cave, "fisheye")
    with pytest.raises(InputError, match="camera count"):
        default_cameras(cave, preset, count=0)


def test_perfect_views_are_exact_and_shaped_like_the_detector_output() -> None:
    cams = default_cameras(box_cave(), "kinect_color")
    person = _person(yaw=30.0)
    views = observe(cams, [person], 7, 1.25, np.random.default_rng(1), FaultConfig.perfect())
    assert len(views) == 4
    for cam, view in zip(cams, views, strict=True):
        assert isinstance(view, ViewDetections) and len(view) == 1
        assert view.camera == cam.name and view.frame_index == 7 and view.timestamp_s == 1.25
        assert view.keypoints_xy.dtype == np.float32 and view.keypoint_scores.shape == (1, 17)
        vis = visibility(cam, [person], 0)
        seen = vis.in_image & ~vis.hidden
        assert np.allclose(view.keypoints_xy[0][seen], project(cam, person)[seen], atol=1e-3)
        assert np.all(view.keypoint_scores[0][seen] == 1.0)
        x1, y1, x2, y2 = view.boxes_xyxy[0]
        kp = view.keypoints_xy[0]
        assert np.all((kp[:, 0] >= x1) & (kp[:, 0] <= x2) & (kp[:, 1] >= y1) & (kp[:, 1] <= y2)), (
            "the box must contain the keypoints"
        )
        assert 0.0 < view.box_scores[0] <= 1.0


def test_joints_outside_the_image_score_zero_with_xy_kept_in_the_image() -> None:
    cam = default_cameras(box_cave(), "depth")[0]  # above the front wall
    person = _person(xy=(0.0, 0.85))  # close under the camera: the feet leave the image
    vis = visibility(cam, [person], 0)
    assert not vis.in_image.all() and vis.in_image.any()
    view = observe([cam], [person], 0, 0.0, np.random.default_rng(0), FaultConfig.perfect())[0]
    assert len(view) == 1
    scores = view.keypoint_scores[0]
    assert np.all(scores[~vis.in_image] == 0.0)
    w, h = cam.image_size
    kp = view.keypoints_xy[0]
    assert np.all(np.isfinite(kp)) and np.all((kp >= 0) & (kp <= [w - 1, h - 1]))


def test_a_person_in_front_hides_the_one_behind_in_that_camera_only() -> None:
    cams = default_cameras(box_cave(), "kinect_color")
    front_cam, back_cam = cams[0], cams[2]  # above the front wall (+Y) and the back wall (-Y)
    navigator = _person((0.0, 0.0), yaw=0.0)
    blocker = _person((0.0, 0.55), yaw=180.0, height=1.9)  # between the navigator and the front camera
    hidden_front = visibility(front_cam, [navigator, blocker], 0).hidden
    hidden_back = visibility(back_cam, [navigator, blocker], 0).hidden
    assert hidden_front.sum() >= 8, f"only {hidden_front.sum()} joints hidden behind the blocker"
    self_hidden_back = visibility(back_cam, [navigator], 0).hidden  # a bent knee may hide itself
    legs = [J["l_hip"], J["r_hip"], J["l_knee"], J["r_knee"]]
    assert (hidden_back & ~self_hidden_back)[legs].sum() == 0, "the blocker hides nothing from behind"
    faults = FaultConfig(person_miss_rate=0.0)
    view, ids = observe_with_ids([front_cam], [navigator, blocker], 0, 0.0, np.random.default_rng(0), faults)[
        0
    ]
    alone = observe([front_cam], [navigator], 0, 0.0, np.random.default_rng(0), faults)[0]
    if (ids == 0).any():  # the navigator may also be missed altogether: too few joints visible
        behind = view.keypoint_scores[ids == 0][0]
        assert behind.mean() < alone.keypoint_scores[0].mean() - 0.15


def test_the_face_is_hidden_from_a_camera_behind_the_head() -> None:
    cams = default_cameras(box_cave(), "kinect_color")
    person = _person(yaw=0.0)  # facing +Y, towards cam01; cam03 is behind
    face = [J["nose"], J["l_eye"], J["r_eye"]]
    assert not visibility(cams[0], [person], 0).hidden[face].any()
    assert visibility(cams[2], [person], 0).hidden[face].all()
    side = visibility(cams[1], [person], 0).hidden  # cam02 at +X sees the right side of the head
    assert side[J["l_ear"]] and not side[J["r_ear"]]


def test_misses_false_detections_and_timestamp_jitter() -> None:
    cams = default_cameras(box_cave(), "kinect_color")
    person = _person()
    rng = np.random.default_rng(3)
    assert all(len(v) == 0 for v in observe(cams, [person], 0, 0.0, rng, FaultConfig(person_miss_rate=1.0)))
    ghosts = observe_with_ids(
        cams, [person], 0, 0.0, rng, FaultConfig(false_detection_rate=3.0, person_miss_rate=0.0)
    )
    n_ghosts = sum(int((ids == -1).sum()) for _, ids in ghosts)
    assert n_ghosts > 3
    for view, ids in ghosts:
        assert (ids == 0).sum() == 1
        assert np.all(np.diff(view.box_scores) <= 0), "detections must come sorted by score"
        assert np.all(view.box_scores[ids == -1] < view.box_scores[ids == 0][0])
        assert np.all((view.keypoint_scores >= 0) & (view.keypoint_scores <= 1))
    stamps = np.array(
        [
            v.timestamp_s
            for f in range(100)
            for v in observe(cams, [person], f, 10.0, rng, FaultConfig(timestamp_jitter_s=0.004))
        ]
    )
    assert 0.002 < stamps.std() < 0.006 and abs(stamps.mean() - 10.0) < 0.002
    assert np.all(
        np.array([v.timestamp_s for v in observe(cams, [person], 0, 10.0, rng, FaultConfig.perfect())])
        == 10.0
    )


def test_noise_grows_with_the_configured_sigma() -> None:
    cam = default_cameras(box_cave(), "kinect_color")[0]
    person = _person()
    exact = project(cam, person)
    errs = []
    for sigma in (1.0, 4.0):
        rng = np.random.default_rng(0)
        faults = FaultConfig.perfect().replace(pixel_noise_px=sigma, occlusion=False)
        d = [
            np.linalg.norm(observe([cam], [person], 0, 0.0, rng, faults)[0].keypoints_xy[0] - exact, axis=1)
            for _ in range(30)
        ]
        errs.append(float(np.mean(d)))
    assert errs[0] > 0.05 and errs[1] > 3 * errs[0]


@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"pixel_noise_px": -1.0}, "pixel_noise_px"),
        ({"person_miss_rate": 1.5}, "person_miss_rate"),
        ({"joint_drop_rate": -0.1}, "joint_drop_rate"),
        ({"score_visible": (1.5, 0.1)}, "scores"),
        ({"score_hidden": (0.6, 0.2)}, "scores"),
        ({"min_visible_keypoints": 0}, "min_visible_keypoints"),
    ],
)
def test_bad_fault_configs_are_rejected(changes: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        FaultConfig().replace(**changes)


def test_observe_rejects_bad_joint_arrays() -> None:
    cams = default_cameras(box_cave(), "depth")
    with pytest.raises(InputError, match=r"person 0: joints must have shape \(17, 3\)"):
        observe(cams, [np.zeros((16, 3))], 0, 0.0, np.random.default_rng(0))
