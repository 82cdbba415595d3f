"""`scripts/combine_action.py`: two trained action models become one file with a start head; the
recogniser, the replay and the bout gate read it (the model card's "two judges")."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import onnx
import onnx.utils
import pytest

from pipeline.recognition.evaluation import network_trace, replay
from pipeline.recognition.features import FEATURES_V3, evidence_vector
from pipeline.recognition.recognizer import (
    DEFAULT_MODEL_PATH,
    ActionRecognizer,
    RecognizerConfig,
    classify_windows,
    classify_windows_heads,
    model_info,
    open_session,
    recognize_sequence,
)
from pipeline.recognition.steps import StepTracker
from pipeline.skeleton import ACTIONS

from .kinematic import Scene, Swing, march, noisy, render

ROOT = Path(__file__).resolve().parents[3]
SCRIPT = ROOT / "scripts" / "combine_action.py"
FPS = 30.0


def _single(tmp: Path, name: str, features: str) -> Path:
    """The committed model's full-body network alone (its first output), labelled ``features``."""
    src = tmp / "committed.onnx"
    out = tmp / name
    onnx.utils.extract_model(str(DEFAULT_MODEL_PATH), str(src), ["x"], ["probs"])
    model = onnx.load(str(src))
    for p in onnx.load(str(DEFAULT_MODEL_PATH)).metadata_props:
        if not p.key.startswith("start_"):
            entry = model.metadata_props.add()
            entry.key, entry.value = p.key, features if p.key == "features" else p.value
    onnx.save(model, str(out))
    return out


def _combine(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, str(SCRIPT), *map(str, args)], capture_output=True, text=True, timeout=120
    )


@pytest.fixture(scope="module")
def models(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path, Path]:
    tmp = tmp_path_factory.mktemp("combine")
    full, legs = _single(tmp, "full.onnx", "v2"), _single(tmp, "legs.onnx", FEATURES_V3)
    out = tmp / "both.onnx"
    done = _combine(full, legs, "--out", out)
    assert done.returncode == 0, done.stderr
    return full, legs, out


def _windows() -> tuple[np.ndarray, np.ndarray]:
    joints, _ = render(Scene(4.0, march(0.5, 5, 0.6, 0.35)))
    j = noisy(joints, 0.012, 0.02, seed=3)
    tracker = StepTracker()
    ev = np.stack([evidence_vector(tracker.update(f, i / FPS)) for i, f in enumerate(j)])
    idx = np.maximum(np.arange(32, len(j))[:, None] - np.arange(31, -1, -1)[None, :], 0)
    return j[idx], ev[idx]


def test_the_combined_file_gives_both_networks_in_one_call(models: tuple[Path, Path, Path]) -> None:
    full, legs, both = models
    session = open_session(both)
    info = model_info(session)
    assert info.start_head and info.features == "v2"
    meta = {p.key: p.value for p in onnx.load(str(both)).metadata_props}
    assert meta["start_features"] == FEATURES_V3 and meta["features"] == "v2"
    windows, evidence = _windows()
    probs, start = classify_windows_heads(session, windows, FPS, evidence)
    assert start is not None
    # the first output is the full-body network, the second the start network fed its own input
    # (the arms and the face masked inside the graph, as model_input does for v3)
    np.testing.assert_allclose(probs, classify_windows(open_session(full), windows, FPS, evidence), atol=1e-6)
    np.testing.assert_allclose(start, classify_windows(open_session(legs), windows, FPS, evidence), atol=1e-6)
    assert np.abs(start - probs).max() > 0.01, "the masked joints change what the start head sees"
    assert classify_windows_heads(open_session(full), windows, FPS, evidence)[1] is None


def test_the_recogniser_streams_what_the_replay_of_both_heads_gives(models: tuple[Path, Path, Path]) -> None:
    _, _, both = models
    swings = (*march(1.0, 8, 0.55, 0.35), Swing(0, 6.0, 6.4, lateral=-0.3, peak=0.05))
    joints, _ = render(Scene(8.0, swings, yaw_deg=40.0))
    j = noisy(joints, 0.012, 0.02, seed=1)
    config = RecognizerConfig(model_path=both)
    rec = ActionRecognizer.from_config(config)
    streamed = np.array([ACTIONS.index(e.label) for e in recognize_sequence(rec, j, FPS)])
    trace = network_trace(rec.session, j, FPS)
    assert trace.start is not None and trace.start.shape == trace.raw.shape
    assert (streamed == replay(trace, config)).all()
    assert (streamed != 0).any(), "the march is a bout"


def test_bad_input_gets_one_error_and_writes_nothing(models: tuple[Path, Path, Path], tmp_path: Path) -> None:
    full, legs, both = models
    out = tmp_path / "x.onnx"
    for args, message in (
        ((tmp_path / "none.onnx", legs), "no such model"),
        ((both, legs), "one output"),
        ((legs, full), "full model must take features v2"),
    ):
        done = _combine(*args, "--out", out)
        assert done.returncode == 2 and done.stderr.startswith("error: "), done.stderr
        assert message in done.stderr, done.stderr
        assert not out.exists()
    (tmp_path / "text.onnx").write_text("not a model")
    done = _combine(tmp_path / "text.onnx", legs, "--out", out)
    assert done.returncode == 2 and done.stderr == "error: text.onnx is not an ONNX model (DecodeError)\n"
    assert not out.exists()
    done = _combine(full, legs, "--out", tmp_path / "text.onnx" / "x.onnx")  # a file as the folder
    assert done.returncode == 2 and done.stderr.startswith("error: ") and done.stderr.count("\n") == 1
    other = onnx.load(str(legs))
    for p in other.metadata_props:
        if p.key == "fps":
            p.value = "60"
    onnx.save(other, str(tmp_path / "fast.onnx"))
    done = _combine(full, tmp_path / "fast.onnx", "--out", out)
    assert done.returncode == 2 and "differ in fps" in done.stderr and not out.exists()
