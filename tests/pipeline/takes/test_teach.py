"""The teach adaptation on the model's outputs: no change when it is the identity, a change the
recogniser sees at once when it is set on the shared session (and none after it is cleared), and a
fit that does better than no change on what it was fitted to."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.errors import InputError
from pipeline.recognition.recognizer import (
    DEFAULT_MODEL_PATH,
    ActionRecognizer,
    RecognizerConfig,
    open_session,
)
from pipeline.runtime.stages import Fusion
from pipeline.takes.teach import AdaptableSession, OutputAdaptation, fit_affine

IDENTITY = OutputAdaptation.from_arrays(np.eye(4), np.zeros(4))
FORWARD = OutputAdaptation.from_arrays(np.eye(4), np.array([0.0, 6.0, 0.0, 0.0]))  # forward favoured


def _march(n: int = 40) -> np.ndarray:
    t = np.arange(n) / 30.0
    j = np.zeros((n, 17, 3))
    j[:, :, 2] = np.linspace(1.7, 0.05, 17)[None, :]
    j[:, 15, 2] = 0.05 + 0.1 * np.clip(np.sin(2 * np.pi * 0.9 * t), 0, None)
    j[:, 16, 2] = 0.05 + 0.1 * np.clip(-np.sin(2 * np.pi * 0.9 * t), 0, None)
    j[:, :, 0] = np.linspace(-0.2, 0.2, 17)[None, :]
    return j


def test_the_identity_changes_nothing_and_a_bias_is_seen_at_once_then_cleared() -> None:
    session = open_session(DEFAULT_MODEL_PATH)
    x = np.random.default_rng(1).normal(size=(3, *session.get_inputs()[0].shape[1:])).astype(np.float32)
    plain = session.run(None, {"x": x})[0]
    adaptable = AdaptableSession(session, IDENTITY)
    assert np.allclose(adaptable.run(None, {"x": x})[0], plain, atol=1e-5)
    config = RecognizerConfig(gate=False)
    rec = ActionRecognizer(adaptable, config)
    fusion = Fusion(recognizer=rec)
    fusion.set_adaptation(FORWARD)
    assert adaptable.adaptation is FORWARD
    probs = [rec.update(f, i / 30.0).probs["forward"] for i, f in enumerate(_march())]
    baseline = ActionRecognizer(session, config)
    base = [baseline.update(f, i / 30.0).probs["forward"] for i, f in enumerate(_march())]
    assert probs[-1] > base[-1] + 0.1, (probs[-1], base[-1])
    fusion.set_adaptation(None)
    assert np.allclose(adaptable.run(None, {"x": x})[0], plain)


def test_the_fit_beats_no_change_on_what_it_was_fitted_to() -> None:
    rng = np.random.default_rng(0)
    y = rng.integers(0, 4, 600)
    logits = rng.normal(size=(600, 4))
    logits[np.arange(600), (y + 1) % 4] += 2.5  # a person the network confuses systematically
    p = np.exp(logits) / np.exp(logits).sum(1, keepdims=True)
    fitted = fit_affine(p, y, l2=0.01)
    assert np.mean(fitted.apply(p).argmax(1) == y) > np.mean(p.argmax(1) == y) + 0.3
    with pytest.raises(InputError, match="no labelled frames"):
        fit_affine(p, np.full(600, -1))
