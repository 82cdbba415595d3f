"""``cavewalk simulate`` through the real command line (it lives in app/, the simulator's front door)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.core.config import set_settings
from pipeline.errors import CavewalkError
from pipeline.skeleton import load_npz

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[3]
SCRIPT = {
    "segments": [
        {"action": "still", "duration_s": 1},
        {"action": "forward", "duration_s": 1.5},
        {"action": "turn", "duration_s": 0.5, "turn_deg": 45},
        {"action": "left", "duration_s": 1},
    ]
}


@pytest.fixture(autouse=True)
def _reset_settings() -> Iterator[None]:
    yield
    set_settings(None)


def test_simulate_writes_the_npz_and_the_per_frame_views(tmp_path: Path) -> None:
    script = tmp_path / "routine.json"
    script.write_text(json.dumps(SCRIPT))
    out, kp = tmp_path / "out" / "seq.npz", tmp_path / "kp.jsonl"
    result = runner.invoke(
        cli,
        [
            "simulate",
            "--script",
            str(script),
            "--out",
            str(out),
            "--keypoints",
            str(kp),
            "--fps",
            "20",
            "--seed",
            "3",
            "--bystanders",
            "1",
        ],
    )
    assert result.exit_code == 0, result.output
    seq = load_npz(out)
    assert len(seq) == 80 and seq.fps == 20.0
    assert seq.labels == ("still",) * 20 + ("forward",) * 30 + ("still",) * 10 + ("left",) * 20
    assert np.all(np.isfinite(seq.joints_m))
    assert seq.source == "sim" and seq.tags is not None and seq.contacts is not None
    assert seq.tags[20:50] == ("march",) * 30 and seq.tags[50:60] == ("turn",) * 10
    assert seq.tags[60:] == ("side-step-out-back",) * 20
    assert seq.contacts.shape == (80, 2) and not seq.contacts[20].all(), "a foot lifts as the bout starts"
    assert seq.contacts[:20].all(), "both feet planted while standing still"
    lines = [json.loads(line) for line in kp.read_text().splitlines()]
    assert [r["frame"] for r in lines] == list(range(80))
    for rec, label in zip(lines, seq.labels, strict=True):
        assert [v["camera"] for v in rec["views"]] == ["cam01", "cam02", "cam03", "cam04"]
        ids = {p["track_id"] for v in rec["views"] for p in v["people"]}
        assert ids <= {0, 1}
        for v in rec["views"]:
            for p in v["people"]:
                assert len(p["keypoints"]) == 17 and len(p["bbox"]) == 4
        assert rec["navigator"] == 0 and rec["action"]["label"] == label
        assert [p["user_id"] for p in rec["people3d"]] == [0, 1]
        assert np.allclose(rec["people3d"][0]["joints"], seq.joints_m[rec["frame"]], atol=1e-3)
    assert "80 frames at 20 fps" in result.output


def test_random_routines_are_reproducible_with_the_seed(tmp_path: Path) -> None:
    outs = []
    for name, seed in (("a", "7"), ("b", "7"), ("c", "8")):
        out = tmp_path / f"{name}.npz"
        result = runner.invoke(
            cli,
            [
                "simulate",
                "--out",
                str(out),
                "--duration",
                "4",
                "--fps",
                "15",
                "--seed",
                seed,
                "--bystanders",
                "0",
            ],
        )
        assert result.exit_code == 0, result.output
        outs.append(load_npz(out))
    assert len(outs[0]) == 60
    assert np.array_equal(outs[0].joints_m, outs[1].joints_m) and outs[0].labels == outs[1].labels
    assert not np.allclose(outs[0].joints_m, outs[2].joints_m)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--script", "missing.json"], "motion script not found"),
        (["--script", "bad.json"], "segment 1: action must be one of"),
        (["--duration", "-2"], "--duration must be a positive number"),
        (["--fps", "0"], "fps must be in"),
        (["--preset", "gopro"], "unknown camera preset"),
    ],
)
def test_bad_input_is_a_clear_error_and_writes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, args: list[str], message: str
) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "bad.json").write_text('{"segments": [{"action": "fly", "duration_s": 1}]}')
    out = tmp_path / "seq.npz"
    result = runner.invoke(cli, ["simulate", "--out", str(out), *args])
    assert isinstance(result.exception, CavewalkError), result.output
    assert message in str(result.exception)
    assert not out.exists(), "rejected input must not leave an output file"


def test_the_installed_command_exits_2_with_one_line(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "simulate",
            "--out",
            str(tmp_path / "s.npz"),
            "--script",
            "nope.json",
        ],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
        env={"PYTHONPATH": str(ROOT), "HOME": str(tmp_path), "PATH": "/usr/bin:/bin"},
    )
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == "error: motion script not found: nope.json"
