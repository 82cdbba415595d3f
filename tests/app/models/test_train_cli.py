"""``cavewalk train`` / ``cavewalk evaluate --takes`` / ``cavewalk models`` through the command line:
one epoch on a tiny take set, evaluate, activate, roll back; a take without labels and a missing
``train`` extra refused (issue 18 items 4 and 7)."""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from pipeline.takes.model_file import check_model_file
from tests.app.models.cli import run
from tests.app.models.takes_data import one_heldout_source, simulated_takes, unlabelled_take

TINY = ["--epochs", "1", "--windows-per-epoch", "256", "--sim", "1", "--sim-duration", "6", "--heldout", "1"]


Cli = Callable[..., tuple[int, str, str]]


@pytest.fixture()
def cavewalk(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Cli:
    monkeypatch.setenv("CAVEWALK_PATHS__CACHE_DIR", str(tmp_path / "cache"))

    def call(*args: str) -> tuple[int, str, str]:
        return run(capsys, monkeypatch, *args)

    return call


@pytest.fixture(scope="module")
def takes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    root = tmp_path_factory.mktemp("takes")
    simulated_takes(root)
    return root


@pytest.mark.slow
def test_train_one_epoch_evaluate_activate_and_roll_back(takes: Path, tmp_path: Path, cavewalk: Cli) -> None:
    db, out = str(tmp_path / "c.db"), tmp_path / "lab.onnx"
    one_heldout_source(tmp_path / "cache")
    code, stdout, stderr = cavewalk("train", "--takes", str(takes), "--out", str(out), *TINY, "--db", db)
    assert code == 0, stdout + stderr
    assert "registered as model 2" in stdout, stdout
    info = check_model_file(out)  # a four-class action model cavewalk can run
    card = json.loads(out.with_suffix(".json").read_text())
    assert [t["participant"] for t in card["data"]["takes"]] == ["P1", "P2"]
    assert [f["participant"] for f in card["folds"]] == ["P1", "P2"], "one LOSO fold per participant"
    conf = card["figures"]["loso_confusion"]
    frames = sum(f["fine_tuned"]["frames"] for f in card["folds"])
    assert len(conf) == 4 and sum(map(sum, conf)) == frames > 0
    assert 0.0 <= card["figures"]["loso_accuracy"] <= 1.0 and card["base_model_id"] == 1
    assert card["figures"]["heldout_sim"]["routines"] == 1
    held = card["figures"]["heldout_sources"]
    assert list(held) == ["blind-heldout"], "the eval sources only, not a training one"
    assert held["blind-heldout"]["clips"] == 1 and held["blind-heldout"]["base"]["frames"] > 0
    for model in ("base", "fine_tuned"):  # a command with no bout, beside the false movement
        fs, fm = held["blind-heldout"][model]["false_starts"], held["blind-heldout"][model]["false_movement"]
        assert 0.0 <= fs <= fm <= 1.0, (model, fs, fm)
    md = out.with_suffix(".md").read_text()
    assert "Leave-one-participant-out" in md and "| P2 | 1 |" in md and "truth \\ predicted" in md
    assert "| blind-heldout | 1 |" in md, "the recognition issue's held-out sources in the card"
    assert "| base false starts | fine-tuned false starts |" in md

    listed = cavewalk("models", "list", "--db", db)[1].splitlines()
    assert listed[1].startswith("    2  trained") and info.sha256[:12] in listed[1], listed

    js = tmp_path / "eval.json"
    code, stdout, stderr = cavewalk(
        "evaluate", "--takes", str(takes), "--model-id", "2", "--db", db, "--json", str(js)
    )
    assert code == 0 and "accuracy" in stdout.lower(), stdout + stderr
    report = json.loads(js.read_text())
    assert report["model"] == str(Path(report["model"])) and report["model"].endswith("action.onnx")
    assert report["frames"] > 0 and 0.0 <= report["accuracy"] <= 1.0, report

    code, stdout, stderr = cavewalk("models", "activate", "2", "--db", db)
    assert code == 0 and stdout.startswith("*   2  trained"), stdout + stderr
    code, stdout, stderr = cavewalk("models", "rollback", "--db", db)
    assert code == 0 and stdout.startswith("*   1  base"), stdout + stderr


def test_training_on_a_take_without_labels_is_refused(takes: Path, tmp_path: Path, cavewalk: Cli) -> None:
    bare = unlabelled_take(tmp_path / "bare")
    db, out = str(tmp_path / "c.db"), tmp_path / "x.onnx"
    code, _out, err = cavewalk(
        "train", "--takes", str(takes), str(bare), "--out", str(out), *TINY, "--db", db
    )
    assert code == 2 and err.startswith("error: take take-P1-s5 has no labels"), err
    assert not out.exists() and not Path(db).exists(), "a refused training writes and registers nothing"


def test_training_without_the_train_extra_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cavewalk: Cli
) -> None:
    monkeypatch.setitem(sys.modules, "torch", None)  # import torch raises ImportError, as when not installed
    code, _out, err = cavewalk("train", "--takes", str(tmp_path), "--out", str(tmp_path / "m.onnx"))
    assert code == 2, err
    assert "training needs the 'train' extra (torch not installed)" in err and "cavewalk[train]" in err
