"""``cavewalk plan`` through the real CLI: the PNG / SVG / JSON it writes, and its clear errors."""

from __future__ import annotations

import json
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.core.config import set_settings
from pipeline.calibration.io import save_calibration, save_pose2sim_toml
from pipeline.cave import box_cave
from pipeline.errors import CavewalkError
from pipeline.sim.scene import default_cameras

ROOT = Path(__file__).resolve().parents[2]
runner = CliRunner()
QUICK = ["--grid", "0.5", "--samples", "1"]


@pytest.fixture(autouse=True)
def _reset_settings():
    yield
    set_settings(None)


def _check_figures(out: Path, names: tuple[str, ...]) -> None:
    for name in names:
        png = (out / f"{name}.png").read_bytes()
        assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000, f"{name}.png is not a drawn PNG"
        root = ET.fromstring((out / f"{name}.svg").read_bytes())
        assert root.tag.endswith("svg") and len(list(root.iter())) > 100, f"{name}.svg is not a drawn SVG"


def test_plan_maps_a_calibration_file_and_writes_png_svg_json(tmp_path: Path) -> None:
    calib = tmp_path / "Calib_proposed.toml"  # a proposed set, in Pose2Sim's format
    save_pose2sim_toml(calib, default_cameras(box_cave(), count=6))
    out = tmp_path / "plan"
    result = runner.invoke(cli, ["plan", "--calibration", str(calib), "--out", str(out), *QUICK])
    assert result.exit_code == 0, result.output
    _check_figures(out, ("coverage",))
    data = json.loads((out / "plan.json").read_text())
    assert data["kind"] == "coverage" and data["source"] == str(calib)
    assert len(data["coverage"]["cameras"]) == 6
    regions = data["summary"]["regions"]
    assert regions["corners"]["error_mm"] > regions["centre"]["error_mm"]
    assert "corners" in result.output and "map in" in result.output


def test_plan_searches_mounts_and_writes_the_best_layout(tmp_path: Path) -> None:
    out = tmp_path / "search"
    cfg = (
        tmp_path / "few_mounts.toml"
    )  # a small search: the search itself is tested in tests/pipeline/planner
    cfg.write_text("[planner]\nmount_heights_m = [2.3]\npans_deg = [0.0]\naim_heights_m = [1.0]\n")
    result = runner.invoke(
        cli, ["--config", str(cfg), "plan", "--cameras", "3", "--out", str(out), "--top", "1", *QUICK]
    )
    assert result.exit_code == 0, result.output
    _check_figures(out, ("coverage", "search"))
    data = json.loads((out / "plan.json").read_text())
    assert data["kind"] == "search" and len(data["search"]["layouts"]) == 1
    assert data["search"]["default"]["name"] == "default"
    best = json.loads((out / "best_layout.json").read_text())
    assert len(best["cameras"]) == 3, "the best layout as a calibration JSON, to plan or mount by"
    again = runner.invoke(
        cli,
        ["plan", "--calibration", str(out / "best_layout.json"), "--out", str(tmp_path / "again"), *QUICK],
    )
    assert again.exit_code == 0, again.output


@pytest.mark.parametrize(
    ("args", "files", "message"),
    [
        (["--calibration", "cams.yaml"], {"cams.yaml": "cameras: []\n"}, "unknown format"),
        (["--calibration", "empty.json"], {"empty.json": '{"cameras": []}'}, "holds no cameras"),
        (["--calibration", "missing.json"], {}, "calibration file not found"),
        (["--calibration", "far.json"], {}, "is outside the room"),
        (["--cameras", "0"], {}, "--cameras must be at least 2"),
        (["--cameras", "12"], {}, "12 cameras need 12 mount spots"),
        (["--cameras", "3", "--calibration", "far.json"], {}, "not both"),
        (["--config", "walls.toml"], {}, "the walls do not close"),
    ],
)
def test_bad_input_is_one_clear_error_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str], files: dict[str, str], message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    save_calibration(tmp_path / "far.json", default_cameras(box_cave(6.0, 6.0, 2.5)))
    walls = box_cave().walls[:3]  # front, right, back: the left side is open
    (tmp_path / "walls.toml").write_text(
        "".join(f"[[cave.walls]]\nname = '{w.name}'\ncorners = {w.corners_m.tolist()}\n" for w in walls)
    )
    if args[0] == "--config":
        argv = [*args, "plan", "--out", "out", *QUICK]
    else:
        argv = ["plan", "--out", "out", *args, *QUICK]
    result = runner.invoke(cli, argv)
    assert isinstance(result.exception, CavewalkError), result.output
    assert message in str(result.exception)
    assert not (tmp_path / "out").exists(), "rejected input must not leave an output folder"


def test_the_installed_command_exits_2_with_one_line(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "plan",
            "--out",
            str(tmp_path / "o"),
            "--calibration",
            "nope.qca.txt",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env={"PYTHONPATH": str(ROOT), "HOME": str(tmp_path), "PATH": "/usr/bin:/bin"},
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == "error: calibration file not found: nope.qca.txt"
