"""`cavewalk record` through the real entry point: its own simulator pipeline, a running server
(``--url``), and bad invocations (one ``error:`` line, exit 2, nothing written)."""

from __future__ import annotations

import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from pipeline.takes.files import check_files
from tests.app.conftest import Served, make_settings
from tests.app.test_cli_errors import run_cli

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--duration", "2", "--protocol", "no-such"], "neither a .toml file nor a shipped protocol"),
        (["--protocol", "four-actions", "--margin", "9"], "--margin must be"),
        (["--protocol", "four-actions", "--margin", "-0.1"], "--margin must be"),
        ([], "give --duration or --protocol"),
        (["--duration", "0"], "--duration must be"),
        (["--duration", "2", "--source", "tv"], "--source must be"),
        (["--duration", "2", "--source", "videos"], "needs --video"),
        (["--duration", "2", "--protocol", "PROTO"], "unknown label 'hop'"),
        (["--duration", "2", "--url", "http://127.0.0.1:9"], "cannot reach the server"),
    ],
)
def test_bad_record_invocations_end_with_one_error_and_write_nothing(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    args: list[str],
    match: str,
) -> None:
    proto = tmp_path / "bad.toml"
    proto.write_text('name = "bad"\nsteps = ["still 2 s", "hop 2 s"]\n')
    args = [str(proto) if a == "PROTO" else a for a in args]
    out = tmp_path / "take"
    code = run_cli(["record", "--out", str(out), *args], monkeypatch)
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and err[-1].startswith("error: ") and match in err[-1], err
    assert not out.exists()


def test_record_refuses_an_existing_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "take").mkdir()
    (tmp_path / "take" / "keep.txt").write_text("mine")
    code = run_cli(["record", "--out", str(tmp_path / "take"), "--duration", "1"], monkeypatch)
    assert code == 2 and "already exists" in capsys.readouterr().err
    assert [p.name for p in (tmp_path / "take").iterdir()] == ["keep.txt"]


@pytest.mark.slow
def test_record_runs_its_own_simulator_pipeline(tmp_path: Path) -> None:
    out = tmp_path / "take"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "record",
            "--out",
            str(out),
            "--protocol",
            "four-actions",
            "--duration",
            "3",
            "--participant",
            "S1",
            "--margin",
            "0.3",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    assert summary["status"] == "complete" and summary["frames"] > 10, summary
    manifest = json.loads((out / "take.json").read_text())
    assert manifest["participant_code"] == "S1" and manifest["protocol"]["name"] == "four actions"
    assert check_files(out) == []
    with np.load(out / "skeletons.npz") as npz:
        assert npz["joints"].shape == (summary["frames"], 17, 3)
        labels = npz["labels"].tolist()
        # the first 3 s of four-actions are still; ignore where the participant was not the navigator
        assert set(labels) <= {"still", "ignore"} and labels.count("still") >= 0.8 * len(labels), labels


@pytest.fixture()
def served(tmp_path: Path) -> Iterator[Served]:
    with Served(make_settings(tmp_path)) as s:
        s.wait_status(lambda st: st["state"] == "running" and st["navigator"] is not None, 60)
        yield s


@pytest.mark.slow
def test_record_on_a_running_server_fetches_the_take(served: Served, tmp_path: Path) -> None:
    out = tmp_path / "fetched"
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "app.cli",
            "record",
            "--out",
            str(out),
            "--url",
            served.base,
            "--protocol",
            str(ROOT / "protocols" / "teach.toml"),
            "--duration",
            "2.5",
            "--participant",
            "R1",
        ],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert "Stand still" in proc.stderr, "the prompt is shown while it records"
    manifest = json.loads((out / "take.json").read_text())
    assert manifest["status"] == "complete" and manifest["participant_code"] == "R1"
    assert check_files(out) == [], "every file came with a matching sha256"
    assert manifest["take_id"] == 1 and (out / "labels.csv").read_text().startswith("t_start,t_end,label")
