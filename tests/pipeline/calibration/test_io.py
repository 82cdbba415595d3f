"""Calibration files: SPEC JSON, Pose2Sim TOML and the demo's real Qualisys file."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pipeline.calibration.io import load_calibration, save_calibration, save_pose2sim_toml
from pipeline.camera import Camera, intrinsics, look_at, project
from pipeline.demo_data import DemoData
from pipeline.errors import InputError


def test_demo_qualisys_file_gives_four_plausible_cameras(demo_data: DemoData) -> None:
    cams = load_calibration(demo_data.calibration)
    assert [c.name for c in cams] == ["cam01", "cam02", "cam03", "cam04"]
    for cam in cams:
        assert cam.image_size == (1088, 1920), "portrait fov_video of the demo"
        horizontal = float(np.linalg.norm(cam.center_m[:2]))
        assert 2.0 < horizontal < 4.5, f"{cam.name} centre {cam.center_m} should be 2-4.5 m from the origin"
        assert 1.5 < cam.center_m[2] < 2.5, f"{cam.name} is mounted at {cam.center_m[2]:.2f} m height"
        assert 1500 < cam.K[0, 0] < 1900, f"{cam.name} focal {cam.K[0, 0]:.0f} px (sensor units / 64)"
        origin, above = project(cam, np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]))
        w, h = cam.image_size
        assert 0 <= origin[0] < w and 0 <= origin[1] < h, f"{cam.name}: origin projects to {origin}"
        assert above[1] < origin[1] - 200, f"{cam.name}: +Z must point up in the image ({above} vs {origin})"
        assert cam.rms_px == pytest.approx(
            {"cam01": 0.402, "cam02": 0.444749, "cam03": 0.450323, "cam04": 0.504772}[cam.name]
        )


def test_demo_cameras_agree_on_a_point_they_all_see(demo_data: DemoData) -> None:
    """Rays of the four cameras through the projections of a point meet at that point."""
    cams = load_calibration(demo_data.calibration)
    from pipeline.camera import undistort_points

    rng = np.random.default_rng(3)
    for point in rng.uniform([-1, -1, 0], [1, 1, 1.8], size=(5, 3)):
        rows = []
        for cam in cams:
            n = undistort_points(cam, project(cam, point[None])[0][None])[0]
            P = np.hstack([cam.R, cam.t[:, None]])
            rows += [n[0] * P[2] - P[0], n[1] * P[2] - P[1]]
        x = np.linalg.svd(np.array(rows))[2][-1]
        assert np.allclose(x[:3] / x[3], point, atol=1e-6)


def test_demo_converts_to_pose2sim_toml_and_json_unchanged(demo_data: DemoData, tmp_path: Path) -> None:
    cams = load_calibration(demo_data.calibration)
    save_pose2sim_toml(tmp_path / "Calib_demo.toml", cams)
    from_toml = load_calibration(tmp_path / "Calib_demo.toml")
    save_calibration(tmp_path / "calib.json", from_toml)
    from_json = load_calibration(tmp_path / "calib.json")
    for a, b, c in zip(cams, from_toml, from_json, strict=True):
        assert a.name == b.name == c.name and a.image_size == b.image_size == c.image_size
        pts = np.array([[0.0, 0.0, 0.0], [0.5, -0.5, 1.7]])
        assert np.allclose(project(a, pts), project(b, pts), atol=1e-6)
        assert b == c


_angle = st.floats(-np.pi, np.pi)


@st.composite
def _cameras(draw: st.DrawFn) -> list[Camera]:
    n = draw(st.integers(1, 5))
    cams = []
    for i in range(n):
        eye = np.array([draw(st.floats(-4, 4)), draw(st.floats(-4, 4)), draw(st.floats(0.5, 3))])
        if np.linalg.norm(eye[:2]) < 0.5:
            eye[0] += 1.0
        R, t = look_at(eye, np.array([0.0, 0.0, 1.0]))
        f = draw(st.floats(300, 3000))
        dist = [draw(st.floats(-0.3, 0.3)), draw(st.floats(-0.1, 0.1)), 0.001, -0.002, 0.0]
        rms = draw(st.one_of(st.just(float("nan")), st.floats(0, 5)))
        K = intrinsics(f, f * 1.001, 960.5, 540.2)
        cams.append(Camera(f"cam{i:02d}", (1920, 1080), K, dist, R, t, rms))
    return cams


@settings(max_examples=25, deadline=None)
@given(cams=_cameras())
def test_calibration_saved_and_loaded_is_the_same(
    tmp_path_factory: pytest.TempPathFactory, cams: list[Camera]
) -> None:
    d = tmp_path_factory.mktemp("calib")
    save_calibration(d / "c.json", cams)
    loaded = load_calibration(d / "c.json")
    assert loaded == cams
    for a, b in zip(cams, loaded, strict=True):
        assert a.rms_px == b.rms_px or (np.isnan(a.rms_px) and np.isnan(b.rms_px))
    save_pose2sim_toml(d / "c.toml", cams)
    for a, b in zip(cams, load_calibration(d / "c.toml"), strict=True):
        # Rodrigues vectors (OpenCV) lose ~1e-7 near 180 degrees: far below any physical effect
        assert a.name == b.name and np.allclose(a.R, b.R, atol=1e-5) and np.allclose(a.t, b.t)
        assert np.allclose(a.K, b.K) and np.allclose(a.dist[:4], b.dist[:4])


_JSON_CAM = (
    '{"name": "c1", "image_size": [640, 480], "K": [[500,0,320],[0,500,240],[0,0,1]], '
    '"dist": [0,0,0,0,0], "R": [[1,0,0],[0,1,0],[0,0,1]], "t": [0,0,3]}'
)


@pytest.mark.parametrize(
    ("name", "content", "match"),
    [
        ("c.json", "{broken", "not valid JSON"),
        ("c.json", '{"cams": []}', "'cameras' list"),
        ("c.json", '{"cameras": []}', "holds no cameras"),
        ("c.json", '{"cameras": [{"name": "c1"}]}', "missing image_size"),
        ("c.json", '{"cameras": [' + _JSON_CAM.replace("[0,0,3]", "[0,0]") + "]}", "t: expected shape"),
        (
            "c.json",
            '{"cameras": [' + _JSON_CAM.replace("[1,0,0],[0,1,0]", "[2,0,0],[0,1,0]") + "]}",
            "not a rotation",
        ),
        ("c.json", '{"cameras": [' + _JSON_CAM + "," + _JSON_CAM + "]}", "must be unique"),
        ("Calib.toml", "[cam_1\nsize=1", "not valid TOML"),
        ("Calib.toml", '[cam_1]\nname = "a"\nsize = [640.0, 480.0]\n', "missing matrix"),
        ("Calib.qca.txt", "<calibration><cameras>", "not valid Qualisys XML"),
        ("Calib.qca.txt", "<calibration><cameras></cameras></calibration>", "no <cameras><camera>"),
        (
            "Calib.qca.txt",
            '<calibration><cameras><camera serial="c1" model="none"/></cameras></calibration>',
            "lacks fov_video",
        ),
        ("calib.yaml", "cameras: []", "unknown format"),
    ],
)
def test_malformed_calibration_is_refused_by_name(
    tmp_path: Path, name: str, content: str, match: str
) -> None:
    path = tmp_path / name
    path.write_text(content)
    with pytest.raises(InputError, match=match):
        load_calibration(path)


def test_missing_calibration_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not found"):
        load_calibration(tmp_path / "none.json")


def test_good_json_camera_loads(tmp_path: Path) -> None:
    path = tmp_path / "c.json"
    path.write_text('{"cameras": [' + _JSON_CAM + "]}")
    (cam,) = load_calibration(path)
    assert cam.name == "c1" and np.isnan(cam.rms_px)
    assert np.allclose(project(cam, np.zeros((1, 3))), [[320, 240]])
