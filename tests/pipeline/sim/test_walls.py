"""Rendered wall images: the ArUco patterns as each virtual camera sees them."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from pipeline.calibration.patterns import make_layout
from pipeline.calibration.pnp import detect_markers
from pipeline.cave import box_cave
from pipeline.errors import InputError
from pipeline.sim.scene import default_cameras
from pipeline.sim.walls import (
    WallRenderConfig,
    marker_corners_px,
    render_camera_view,
    render_camera_views,
    render_wall_views,
)

CAVE = box_cave()
LAYOUT = make_layout(CAVE)


def _corner_errors(image: np.ndarray, cam) -> tuple[np.ndarray, set[int]]:  # type: ignore[no-untyped-def]
    det = detect_markers(image)
    truth = marker_corners_px(cam, LAYOUT)
    errs = np.array(
        [np.linalg.norm(c - truth[int(i)], axis=1) for i, c in zip(det.ids, det.corners_px, strict=True)]
    )
    return errs.reshape(-1), {int(i) for i in det.ids}


def _fully_visible(cam) -> set[int]:  # type: ignore[no-untyped-def]
    w, h = cam.image_size
    out = set()
    for marker_id, uv in marker_corners_px(cam, LAYOUT).items():
        z = (LAYOUT.marker(marker_id).corners_m @ cam.R.T + cam.t)[:, 2]
        if np.all(z > 0) and np.all((uv >= 3) & (uv < [w - 3, h - 3])):
            out.add(marker_id)
    return out


@pytest.mark.parametrize("preset", ["depth", pytest.param("kinect_color", marks=pytest.mark.slow)])
def test_marker_corners_are_detected_where_the_camera_projects_them(preset: str) -> None:
    cam = default_cameras(CAVE, preset)[1]
    image = render_camera_view(cam, CAVE, LAYOUT, np.random.default_rng(0), WallRenderConfig.clean())
    assert image.shape == (cam.image_size[1], cam.image_size[0], 3) and image.dtype == np.uint8
    errs, found = _corner_errors(image, cam)
    assert len(found) >= 12, f"only {len(found)} markers detected"
    assert found <= _fully_visible(cam), "a marker was detected where it cannot be seen"
    assert errs.max() < 1.0, f"corner error up to {errs.max():.2f} px"


@pytest.mark.slow
def test_realistic_renders_of_every_camera_keep_corners_within_a_pixel() -> None:
    cams = default_cameras(CAVE, "depth")
    views = render_wall_views(CAVE, LAYOUT, cams, seed=3)
    assert set(views) == {c.name for c in cams}
    for cam in cams:
        img = views[cam.name]
        errs, found = _corner_errors(img, cam)
        assert len(found) >= 0.8 * len(_fully_visible(cam)), f"{cam.name}: markers missed"
        # blur, noise, vignetting and different wall brightness move a few corners next to the
        # wall seams (as in real captures); the rest stay within a pixel
        assert np.median(errs) < 0.5 and np.mean(errs < 1.0) > 0.95, f"{cam.name}: {np.sort(errs)[-5:]}"
    # the walls differ in brightness, and renders differ with the seed
    again = render_wall_views(CAVE, LAYOUT, cams[:1], seed=3)
    other = render_wall_views(CAVE, LAYOUT, cams[:1], seed=4)
    assert np.array_equal(again["cam01"], views["cam01"])
    assert not np.array_equal(other["cam01"], views["cam01"])


def test_settings_like_objects_give_named_simulated_cameras() -> None:
    settings = SimpleNamespace(
        sim=SimpleNamespace(camera_preset="depth"),
        cameras=[SimpleNamespace(name="north"), SimpleNamespace(name="east")],
    )
    views = render_camera_views(settings, CAVE, LAYOUT, seed=0, config=WallRenderConfig(supersample=1))
    assert sorted(views) == ["east", "north"]
    assert views["north"].shape == (576, 640, 3)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"supersample": 0}, "supersample"),
        ({"wall_gain": (1.0, 0.5)}, "wall_gain"),
        ({"noise_sd": -1.0}, "noise_sd"),
        ({"black_level": (50.0, 10.0)}, "black_level"),
    ],
)
def test_bad_render_configs_are_rejected(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(InputError, match=match):
        WallRenderConfig(**kwargs)  # type: ignore[arg-type]
    with pytest.raises(InputError, match="no cameras"):
        render_wall_views(CAVE, LAYOUT, [])


@pytest.mark.slow
def test_the_calibration_stage_recovers_the_ground_truth_cameras_from_the_renders() -> None:
    from pipeline.calibration.pnp import calibrate_cameras

    truth = default_cameras(CAVE, "depth", rng=np.random.default_rng(1), jitter_m=0.05, jitter_deg=3.0)
    views = render_wall_views(CAVE, LAYOUT, truth, seed=0)
    solved = calibrate_cameras({name: [img] for name, img in views.items()}, LAYOUT)
    for cam in truth:
        got = solved[cam.name]
        assert got.rms_px < 1.0, got.summary()
        assert np.linalg.norm(got.camera.center_m - cam.center_m) < 0.02, got.summary()
        assert abs(got.camera.K[0, 0] / cam.K[0, 0] - 1.0) < 0.01, got.summary()
