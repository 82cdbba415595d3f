"""Kicks from standing through the real recogniser (the committed model and the gate), on the
skeletons of `scripts/kick_probe.py`: the standing after each kick is never movement."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from pipeline.recognition import corpus
from pipeline.recognition.bout import GateConfig
from pipeline.recognition.evaluation import evaluate_recognizer
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig

from .conftest import standing_pose

ROOT = Path(__file__).resolve().parents[3]
PROBE = ROOT / "scripts" / "kick_probe.py"


def _probe(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(PROBE), *args], capture_output=True, text=True, timeout=120, check=False
    )


def _false_movement(evaluation, tag: str) -> float:  # type: ignore[no-untyped-def]
    row = next(g for g in evaluation.per_tag if g.name == tag)
    assert row.false_movement is not None
    return float(row.false_movement)


def test_standing_after_a_kick_is_still(tmp_path: Path) -> None:
    pose = tmp_path / "pose.npz"
    np.savez(pose, joints=standing_pose()[None].astype(np.float32))
    done = _probe("--pose", str(pose), "--out", str(tmp_path / "out"), "--seeds", "0", "1")
    assert done.returncode == 0, done.stderr
    seqs = corpus.from_folder(tmp_path / "out")
    assert len(seqs) == 2 and all((s.tags == "kick").sum() == 4 * 27 for s in seqs)
    now = evaluate_recognizer(ActionRecognizer.from_config(RecognizerConfig()), seqs)
    assert _false_movement(now, "(untagged)") == 0.0, "standing after a kick is called movement"
    assert _false_movement(now, "kick") < 0.5  # the kick's first frames may start a bout
    no_rule = replace(RecognizerConfig(), gate_config=GateConfig(kick_deg=float("inf")))
    old = ActionRecognizer.from_config(no_rule)
    assert _false_movement(evaluate_recognizer(old, seqs), "(untagged)") > 0.05, "the rule is what stops it"


def test_bad_input_is_one_error_and_writes_nothing(tmp_path: Path) -> None:
    bad = tmp_path / "bad.npz"
    np.savez(bad, joints=np.zeros((1, 5, 3), np.float32))
    pose = tmp_path / "pose.npz"
    np.savez(pose, joints=standing_pose()[None].astype(np.float32))
    a_file = tmp_path / "a-file"
    a_file.write_text("x")
    for args, words in (
        (("--pose", str(bad), "--out", str(tmp_path / "out")), "not a whole skeleton"),
        (("--pose", str(tmp_path / "missing.npz"), "--out", str(tmp_path / "out")), "not a SPEC skeleton"),
        (("--pose", str(pose), "--out", str(tmp_path / "out"), "--raise", "nan"), "--raise"),
        (("--pose", str(pose), "--out", str(tmp_path / "out"), "--raise", "0"), "--raise"),
        (("--pose", str(pose), "--out", str(a_file)), "cannot be a folder"),
    ):
        done = _probe(*args)
        assert done.returncode == 2, (args, done.stderr)
        assert done.stderr.startswith("error: ") and done.stderr.count("\n") == 1, done.stderr
        assert words in done.stderr, done.stderr
    assert not (tmp_path / "out").exists() and a_file.read_text() == "x"
