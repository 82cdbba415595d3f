"""``cavewalk calibration pattern|layout|checkerboard`` and ``cavewalk calibrate`` through the real CLI."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.core.config import set_settings
from pipeline.calibration.io import load_calibration
from pipeline.calibration.patterns import load_layout, make_layout
from pipeline.calibration.pnp import detect_markers
from pipeline.cave import box_cave
from pipeline.demo_data import DemoData
from pipeline.errors import CalibrationError, InputError
from tests.app.test_cli_errors import run_cli
from tests.pipeline.calibration.synthetic import render, small_cameras

runner = CliRunner()


@pytest.fixture(autouse=True)
def _reset_settings() -> Iterator[None]:
    yield
    set_settings(None)


@pytest.fixture(scope="module")
def wall_views(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two cameras' rendered views of the default CAVE's wall patterns, as PNG files."""
    cave = box_cave()
    layout = make_layout(cave)
    folder = tmp_path_factory.mktemp("views")
    out = {}
    for cam in small_cameras(cave, 2):
        path = folder / f"{cam.name}.png"
        cv2.imwrite(str(path), render(cam, cave, layout, seed=1))
        out[cam.name] = path
    return out


def test_layout_and_pattern_commands_write_matching_files(tmp_path: Path) -> None:
    result = runner.invoke(cli, ["calibration", "layout", "--out", str(tmp_path / "layout.json")])
    assert result.exit_code == 0, result.output
    layout = load_layout(tmp_path / "layout.json")
    assert len(layout.markers) == 120 and "120 markers" in result.output
    out = tmp_path / "right.png"
    result = runner.invoke(
        cli,
        [
            "calibration",
            "pattern",
            "--wall",
            "right",
            "--out",
            str(out),
            "--layout",
            str(tmp_path / "layout.json"),
        ],
    )
    assert result.exit_code == 0, result.output
    img = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    assert img.shape == (1600, 1920)
    assert sorted(detect_markers(img).ids.tolist()) == sorted(m.id for m in layout.on_wall("right"))


def test_calibrate_writes_calibration_and_overlays(tmp_path: Path, wall_views: dict[str, Path]) -> None:
    args = ["calibrate", "--out", str(tmp_path / "calib.json"), "--overlay-dir", str(tmp_path / "ov")]
    args += ["--toml", str(tmp_path / "Calib.toml")]
    for name, path in wall_views.items():
        args += ["--image", f"{name}={path}"]
    result = runner.invoke(cli, args)
    assert result.exit_code == 0, result.output
    cams = load_calibration(tmp_path / "calib.json")
    assert [c.name for c in cams] == ["cam01", "cam02"]
    assert all(c.rms_px < 0.5 for c in cams)
    assert "cam01: RMS" in result.output and "good" in result.output
    assert [c.name for c in load_calibration(tmp_path / "Calib.toml")] == ["cam01", "cam02"]
    for name in wall_views:
        ov = cv2.imread(str(tmp_path / "ov" / f"{name}_overlay.png"))
        assert ov is not None and ov.shape == (720, 1280, 3)


def _bad_cases(tmp: Path, views: dict[str, Path]) -> list[tuple[list[str], type[Exception], str]]:
    (tmp / "text.png").write_text("not an image")
    (tmp / "bad_layout.json").write_text('{"dictionary": "DICT_4X4_250", "markers": [{"id": 1}]}')
    blank = tmp / "blank.png"
    cv2.imwrite(str(blank), np.full((480, 640), 128, np.uint8))
    out = ["--out", str(tmp / "calib.json")]
    return [
        (["calibrate", "--image", f"cam01={tmp / 'missing.png'}", *out], InputError, "image not found"),
        (["calibrate", "--image", f"cam01={tmp / 'text.png'}", *out], InputError, "cannot read image"),
        (["calibrate", "--image", str(views["cam01"]), *out], InputError, "must be NAME=PATH"),
        (
            [
                "calibrate",
                "--image",
                f"cam01={views['cam01']}",
                "--layout",
                str(tmp / "bad_layout.json"),
                *out,
            ],
            InputError,
            "malformed marker layout .*missing 'wall', 'corners'",
        ),
        (
            ["calibrate", "--image", f"cam01={views['cam01']}", "--layout", str(tmp / "none.json"), *out],
            InputError,
            "marker layout not found",
        ),
        (["calibrate", "--image", f"cam01={blank}", *out], CalibrationError, "cam01 sees 0 usable markers"),
        (
            ["calibration", "pattern", "--wall", "ceiling", "--out", str(tmp / "w.png")],
            InputError,
            "unknown wall",
        ),
        (
            ["calibration", "pattern", "--wall", "front", "--out", str(tmp / "w.xyz")],
            InputError,
            "cannot write",
        ),
        (
            ["calibration", "checkerboard", "--images", f"cam01={tmp / 'nowhere'}"],
            InputError,
            "checkerboard images not found",
        ),
    ]


_CASE_IDS = ["missing", "unreadable", "no-name", "bad-layout", "no-layout", "blank", "wall", "ext", "cb"]


@pytest.mark.parametrize("case", range(len(_CASE_IDS)), ids=_CASE_IDS)
def test_bad_input_is_one_clear_error_and_writes_nothing(
    tmp_path: Path, wall_views: dict[str, Path], case: int
) -> None:
    args, exc_type, match = _bad_cases(tmp_path, wall_views)[case]
    result = runner.invoke(cli, args)
    assert isinstance(result.exception, exc_type), (result.exception, result.output)
    with pytest.raises(exc_type, match=match):
        raise result.exception
    assert not (tmp_path / "calib.json").exists(), "a refused calibration leaves no output file"


def test_bad_input_exits_2_without_traceback(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    # the real entry point app.cli.main in this process (an interpreter costs ~3 s of imports; an
    # exception escaping main() fails the test)
    code = run_cli(["calibrate", "--image", f"cam01={tmp_path / 'x.png'}", "--out", str(tmp_path / "c.json")],
                   monkeypatch)
    err = capsys.readouterr().err
    assert code == 2, err
    assert "error: cam01: image not found" in err and "Traceback" not in err


def test_checkerboard_command_on_the_real_demo_images(demo_data: DemoData, tmp_path: Path) -> None:
    folder = demo_data.intrinsics_images / "int_cam01_img"
    result = runner.invoke(
        cli, ["calibration", "checkerboard", "--images", f"cam01={folder}", "--out", str(tmp_path / "k.json")]
    )
    assert result.exit_code == 0, result.output
    (cam,) = load_calibration(tmp_path / "k.json")
    assert cam.image_size == (1088, 1920)
    assert cam.rms_px < 0.5, result.output
    # the demo's Qualisys calibration of the same camera: f = 1681 px
    assert cam.K[0, 0] == pytest.approx(1681, rel=0.02)
    assert "cam01: RMS" in result.output


def test_calibrate_pools_the_frames_of_a_short_clip(tmp_path: Path, wall_views: dict[str, Path]) -> None:
    frame = cv2.imread(str(wall_views["cam01"]))
    clip = tmp_path / "cam01.avi"
    writer = cv2.VideoWriter(str(clip), cv2.VideoWriter_fourcc(*"MJPG"), 10, (frame.shape[1], frame.shape[0]))
    assert writer.isOpened(), "OpenCV can write MJPG AVI"
    for _ in range(5):
        writer.write(frame)
    writer.release()
    args = ["calibrate", "--image", f"cam01={clip}", "--image", f"cam02={wall_views['cam02']}"]
    result = runner.invoke(cli, [*args, "--max-frames", "3", "--out", str(tmp_path / "c.json")])
    assert result.exit_code == 0, result.output
    assert "cam01: 3 image(s)" in result.output and "cam02: 1 image(s)" in result.output
    assert load_calibration(tmp_path / "c.json")[0].rms_px < 0.6
