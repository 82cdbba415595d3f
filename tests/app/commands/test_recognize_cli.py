"""``cavewalk recognize`` end to end through the real entry point, and its bad-input cases."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pipeline.sim.body import body_from_height
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import MotionScript, Segment
from pipeline.skeleton import ACTIONS, SkeletonSequence, save_npz
from tests.app.commands.conftest import run_cli


@pytest.fixture(scope="module")
def routine_npz(tmp_path_factory: pytest.TempPathFactory) -> Path:
    segs = (Segment("still", 2.0), Segment("forward", 3.0), Segment("right", 3.0), Segment("still", 2.0))
    m = simulate_user(MotionScript(segs, start_yaw_deg=-60.0), body_from_height(1.7), 30.0, seed=21)
    path = tmp_path_factory.mktemp("rec") / "routine.npz"
    save_npz(path, m.to_sequence())
    return path


def test_recognize_writes_one_line_per_frame(
    routine_npz: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "sub" / "a.jsonl"
    assert run_cli(monkeypatch, "recognize", "--skeletons", str(routine_npz), "--out", str(out)) == 0
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    assert len(lines) == 300
    assert [r["frame"] for r in lines] == list(range(300))
    assert set(lines[0]) == {"frame", "action", "probs", "yaw_deg", "speed_mps"}
    assert all(r["action"] in ACTIONS and set(r["probs"]) == set(ACTIONS) for r in lines)
    assert [r["action"] for r in lines[30:60]].count("still") == 30
    assert [r["action"] for r in lines[120:150]].count("forward") >= 27
    assert [r["action"] for r in lines[210:240]].count("right") >= 27
    assert abs(np.median([r["yaw_deg"] for r in lines[30:]]) + 60.0) < 10.0
    assert all(r["speed_mps"] == 0 for r in lines if r["action"] == "still")
    assert "300 frames" in capsys.readouterr().out


def test_recognize_honours_the_file_fps(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    segs = (Segment("still", 2.0), Segment("left", 3.0))
    m = simulate_user(MotionScript(segs), body_from_height(1.85), 60.0, seed=4)
    src = tmp_path / "s60.npz"
    save_npz(src, m.to_sequence())
    out = tmp_path / "a60.jsonl"
    assert run_cli(monkeypatch, "recognize", "--skeletons", str(src), "--out", str(out)) == 0
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    assert len(lines) == 300, "one line per input frame, not per model frame"
    assert [r["action"] for r in lines[-60:]].count("left") >= 54


def _bad_files(tmp: Path) -> dict[str, tuple[Path, str]]:
    text = tmp / "text.npz"
    text.write_text("hello")
    wrong = tmp / "wrong.npz"
    np.savez(wrong, joints=np.zeros((10, 16, 3)), fps=30.0)
    nofps = tmp / "nofps.npz"
    np.savez(nofps, joints=np.zeros((10, 17, 3)))
    empty = tmp / "empty.npz"
    save_npz(empty, SkeletonSequence(np.zeros((0, 17, 3)), 30.0))
    badfps = tmp / "badfps.npz"
    np.savez(badfps, joints=np.zeros((10, 17, 3)), fps=0.0)
    return {
        "missing": (tmp / "nope.npz", "not found"),
        "text": (text, "not an NPZ file"),  # issue 15: it said "pickled (object) data"
        "wrong": (wrong, r"\(T, 17, 3\)"),
        "nofps": (nofps, "'fps'"),
        "empty": (empty, "no frames"),
        "badfps": (badfps, "fps"),
    }


@pytest.mark.parametrize("case", ["missing", "text", "wrong", "nofps", "empty", "badfps"])
def test_bad_skeleton_files_end_with_one_message(
    case: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import re

    path, match = _bad_files(tmp_path)[case]
    out = tmp_path / "a.jsonl"
    out.write_text("previous results\n")
    assert run_cli(monkeypatch, "recognize", "--skeletons", str(path), "--out", str(out)) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: ") and re.search(match, err), err
    assert "Traceback" not in err
    assert out.read_text() == "previous results\n", "a rejected input leaves the old output as it was"


def test_bad_model_and_bad_output(
    routine_npz: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    code = run_cli(
        monkeypatch,
        "recognize",
        "--skeletons",
        str(routine_npz),
        "--out",
        str(tmp_path / "a.jsonl"),
        "--model",
        str(tmp_path / "missing.onnx"),
    )
    assert code == 2 and "action model not found" in capsys.readouterr().err
    assert not (tmp_path / "a.jsonl").exists()
    code = run_cli(monkeypatch, "recognize", "--skeletons", str(routine_npz), "--out", str(tmp_path))
    assert code == 2 and "is a directory" in capsys.readouterr().err


@pytest.mark.parametrize("value", [np.nan, np.inf])
def test_recognize_without_data_says_still_with_confidence_zero_and_warns(
    value: float, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    src = tmp_path / "blank.npz"
    np.savez(src, joints=np.full((100, 17, 3), value), fps=30.0)
    out = tmp_path / "a.jsonl"
    assert run_cli(monkeypatch, "recognize", "--skeletons", str(src), "--out", str(out)) == 0
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    assert len(lines) == 100
    assert all(r["action"] == "still" and max(r["probs"].values()) == 0.0 and r["no_data"] for r in lines)
    assert all(r["speed_mps"] == 0.0 for r in lines)
    assert "warning: 100 of 100 frames had no usable skeleton" in capsys.readouterr().err
