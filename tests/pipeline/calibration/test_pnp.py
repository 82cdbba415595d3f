"""PnP calibration from rendered camera views of the wall patterns (ground truth known)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.calibration.config import CalibrationConfig
from pipeline.calibration.overlay import calibration_overlay, encode_png
from pipeline.calibration.patterns import MarkerLayout, make_layout
from pipeline.calibration.pnp import (
    MarkerDetections,
    calibrate_camera,
    calibrate_cameras,
    decompose_projection,
    detect_markers,
    dlt_projection,
)
from pipeline.camera import Camera, intrinsics, look_at, project
from pipeline.cave import CaveGeometry, box_cave
from pipeline.errors import CalibrationError, InputError
from tests.pipeline.calibration.synthetic import SIZE, render, small_cameras


@pytest.fixture(scope="module")
def scene() -> tuple[CaveGeometry, MarkerLayout, list[Camera]]:
    cave = box_cave()
    return cave, make_layout(cave), small_cameras(cave)


@pytest.fixture(scope="module")
def views(scene: tuple[CaveGeometry, MarkerLayout, list[Camera]]) -> dict[str, np.ndarray]:
    cave, layout, cams = scene
    return {c.name: render(c, cave, layout, seed=7 + i) for i, c in enumerate(cams[:2])}


def _errors(truth: Camera, solved: Camera) -> tuple[float, float, float]:
    pos_mm = float(np.linalg.norm(truth.center_m - solved.center_m)) * 1000
    rot_deg = float(np.rad2deg(np.linalg.norm(cv2.Rodrigues(solved.R @ truth.R.T)[0])))
    focal_pct = float(abs(solved.K[0, 0] / truth.K[0, 0] - 1) * 100)
    return pos_mm, rot_deg, focal_pct


def test_rendered_views_give_back_the_true_cameras(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]], views: dict[str, np.ndarray]
) -> None:
    _, layout, cams = scene
    results = calibrate_cameras({name: [img] for name, img in views.items()}, layout)
    assert list(results) == ["cam01", "cam02"]
    for truth in cams[:2]:
        res = results[truth.name]
        pos_mm, rot_deg, focal_pct = _errors(truth, res.camera)
        # 1280x720 views at 1 sample/pixel: looser than the benchmark's full-HD figures
        assert res.rms_px < 0.5, res.summary()
        assert pos_mm < 20 and rot_deg < 0.1 and focal_pct < 0.5, (pos_mm, rot_deg, focal_pct)
        # lens model: the solved camera maps every marker corner it saw where the true one does
        seen = res.object_points_m[res.inliers]
        gap = np.linalg.norm(project(res.camera, seen) - project(truth, seen), axis=1)
        assert gap.max() < 0.5, f"{truth.name}: solved and true cameras differ by {gap.max():.2f} px"
        assert len(res.walls_seen) >= 2 and res.markers_used >= 20
        assert res.verdict == "good" and res.camera.rms_px == pytest.approx(res.rms_px)


def test_a_misidentified_marker_is_rejected(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]], views: dict[str, np.ndarray]
) -> None:
    _, layout, cams = scene
    det = detect_markers(views["cam01"], layout.dictionary)
    wrong = det.ids.copy()
    wrong[0], wrong[1] = det.ids[1], det.ids[0]  # two markers swap identities
    res = calibrate_camera("cam01", [MarkerDetections(det.image_size, wrong, det.corners_px)], layout)
    assert res.corners_rejected >= 8, "both swapped markers' corners are outliers"
    assert not res.inliers[:8].any()
    pos_mm, rot_deg, focal_pct = _errors(cams[0], res.camera)
    assert pos_mm < 20 and rot_deg < 0.1 and focal_pct < 0.5


def test_several_images_of_a_camera_are_pooled(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]], views: dict[str, np.ndarray]
) -> None:
    cave, layout, cams = scene
    second = render(cams[1], cave, layout, seed=99)
    dets = [detect_markers(img, layout.dictionary) for img in (views["cam02"], second)]
    res = calibrate_camera("cam02", dets, layout)
    assert res.images_used == 2
    assert res.corners_used + res.corners_rejected == sum(4 * len(d.ids) for d in dets)
    pos_mm, rot_deg, focal_pct = _errors(cams[1], res.camera)
    assert pos_mm < 20 and rot_deg < 0.1 and focal_pct < 0.5


def test_one_wall_only_is_refused_with_what_is_missing(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]],
) -> None:
    cave, layout, cams = scene
    img = render(cams[1], cave, layout, seed=3, walls=("left",))
    with pytest.raises(
        CalibrationError, match=r"cam02 .*1 wall\(s\) \(left\); need markers on at least 2 walls"
    ):
        calibrate_cameras({"cam02": [img]}, layout)


def test_too_few_markers_are_refused_and_every_failing_camera_is_named(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]], views: dict[str, np.ndarray]
) -> None:
    _, layout, _ = scene
    blank = np.full((SIZE[1], SIZE[0]), 128, np.uint8)
    with pytest.raises(
        CalibrationError, match=r"camera camA sees 0 usable markers \(need at least 6\)"
    ) as exc:
        calibrate_cameras({"camA": [blank], "cam01": [views["cam01"]], "camB": [blank]}, layout)
    assert "camB" in str(exc.value) and "cam01" not in str(exc.value)
    few = CalibrationConfig(min_markers=100)
    with pytest.raises(CalibrationError, match=r"need at least 100"):
        calibrate_cameras({"cam01": [views["cam01"]]}, layout, few)


@pytest.mark.parametrize(
    ("images", "match"),
    [
        ({}, "no camera images"),
        ({"cam01": []}, "no images given"),
        ({"cam01": [np.zeros((10, 10), np.float32)]}, "8-bit grey or BGR"),
        ({"cam01": [np.zeros((10, 10, 2), np.uint8)]}, "8-bit grey or BGR"),
    ],
)
def test_bad_images_are_input_errors(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]], images: dict[str, list[np.ndarray]], match: str
) -> None:
    with pytest.raises(InputError, match=match):
        calibrate_cameras(images, scene[1])


def test_images_of_different_sizes_are_refused(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]],
) -> None:
    dets = [
        MarkerDetections((640, 480), np.empty(0), np.empty((0, 4, 2))),
        MarkerDetections((1280, 720), np.empty(0), np.empty((0, 4, 2))),
    ]
    with pytest.raises(InputError, match="same size"):
        calibrate_camera("cam01", dets, scene[1])


@settings(max_examples=25, deadline=None)
@given(
    eye=st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0.5, 3)),
    f=st.floats(400, 3000),
    cx=st.floats(500, 800),
    cy=st.floats(300, 450),
)
def test_dlt_and_decomposition_recover_a_pinhole_camera(
    eye: tuple[float, float, float], f: float, cx: float, cy: float
) -> None:
    e = np.array(eye)
    if np.linalg.norm(e[:2]) < 0.5:
        e[0] += 1.0
    R, t = look_at(e, np.array([0.0, 0.0, 1.0]))
    cam = Camera("c", (1280, 720), intrinsics(f, f, cx, cy), np.zeros(5), R, t)
    in_cam = np.random.default_rng(0).uniform([-1, -0.6, 1.0], [1, 0.6, 4.0], size=(40, 3))
    in_cam[:, :2] *= in_cam[:, 2:]  # inside the view frustum, 1-4 m deep
    pts = (in_cam - t) @ R  # camera -> world
    K, R2, t2 = decompose_projection(dlt_projection(pts, project(cam, pts)))
    assert np.allclose(K, cam.K, rtol=1e-6, atol=1e-5)
    assert np.allclose(R2, R, atol=1e-8) and np.allclose(t2, t, atol=1e-7)


def test_overlay_draws_over_the_camera_image(
    scene: tuple[CaveGeometry, MarkerLayout, list[Camera]], views: dict[str, np.ndarray]
) -> None:
    cave, layout, _ = scene
    img = views["cam01"]
    res = calibrate_camera("cam01", [detect_markers(img, layout.dictionary)], layout)
    ov = calibration_overlay(res, cave, img)
    assert ov.shape == (SIZE[1], SIZE[0], 3) and ov.dtype == np.uint8
    # The Z axis (blue) starts at the projected origin.
    origin = project(res.camera, np.zeros((1, 3)))[0]
    z_tip = project(res.camera, np.array([[0.0, 0.0, 0.25]]))[0]
    u, v = np.round((origin + z_tip) / 2).astype(int)
    b, g, r = ov[v, u].astype(int)
    assert b > 200 and r < 100, f"blue Z axis expected at {(u, v)}, got BGR {(b, g, r)}"
    # Detected corners are drawn in green.
    du, dv = np.round(res.image_points_px[res.inliers][0]).astype(int)
    patch = ov[dv - 6 : dv + 7, du - 6 : du + 7].reshape(-1, 3).astype(int)
    assert np.any((patch[:, 1] > 150) & (patch[:, 0] < 80) & (patch[:, 2] < 80)), "green corner ring"
    png = encode_png(ov)
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR).shape == ov.shape
    with pytest.raises(InputError, match="expected a 1280x720"):
        calibration_overlay(res, cave, np.zeros((10, 10), np.uint8))
