"""Teach: the recogniser adapted to one participant from a short prompted take (issue 18 item 3).

At the start of a session the participant follows the 60-second ``teach`` protocol (every action
twice). :func:`fit_adaptation` refits the network's output layer to that person in its simplest
form: an affine map of the network's log-probabilities, ``q = softmax(W log p + b)`` (4 x 4 + 4
numbers; W = I, b = 0 is no change), fitted by class-balanced cross-entropy on the first part of
the take, pulled towards no change (L2 on W - I and b), with scipy's L-BFGS. It moves the decision
boundaries between the classes (the thresholds) and how sure each class is; the EMA, hysteresis
and stepping-bout gate then work on the adapted probabilities as before. It reports the streaming
recogniser's accuracy before and after on the held-back last part of the take (every action
occurs in both halves of the teach protocol), and is worth switching on only when it does not do
worse there (:attr:`TeachResult.helps`).

At run time :class:`AdaptableSession` wraps the model's onnxruntime session: every recogniser
sharing it gets the adapted outputs, and the adaptation can be set or cleared at any moment (the
participant's session starts or stops, the operator switches it off) without reloading anything.
numpy and scipy only: no torch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.recognition import corpus
from pipeline.recognition.dataset import IGNORE_INDEX, LabelledSequence
from pipeline.recognition.evaluation import NetworkTrace, network_trace, replay, scored
from pipeline.recognition.metrics import evaluate
from pipeline.recognition.recognizer import RecognizerConfig, model_info
from pipeline.skeleton import ACTIONS

METHOD = "affine-logp"
_EPS = 1e-6
_K = len(ACTIONS)


@dataclass(frozen=True, slots=True)
class OutputAdaptation:
    """``q = softmax(W log p + b)`` on the network's class probabilities ``p`` (ACTIONS order).

    weights: 4 x 4 (rows = output class), bias: 4; adaptation_id: the registry's id (None: not stored).
    """

    weights: tuple[tuple[float, ...], ...]
    bias: tuple[float, ...]
    adaptation_id: int | None = None
    participant_code: str | None = None

    def __post_init__(self) -> None:
        w = np.asarray(self.weights, dtype=np.float64)
        b = np.asarray(self.bias, dtype=np.float64)
        if w.shape != (_K, _K) or b.shape != (_K,) or not (np.isfinite(w).all() and np.isfinite(b).all()):
            raise InputError(
                f"an adaptation is {_K} x {_K} finite weights and {_K} biases, got {w.shape}, {b.shape}"
            )

    @classmethod
    def from_arrays(cls, w: NDArray[np.floating], b: NDArray[np.floating], **kw: Any) -> OutputAdaptation:
        return cls(tuple(tuple(float(v) for v in row) for row in w), tuple(float(v) for v in b), **kw)

    @classmethod
    def from_params(cls, params: dict[str, Any], **kw: Any) -> OutputAdaptation:
        """From the stored JSON (``{"weights": [[...]], "bias": [...]}``)."""
        try:
            return cls.from_arrays(
                np.asarray(params["weights"], float), np.asarray(params["bias"], float), **kw
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"not an adaptation's parameters: {exc}") from None

    def params(self) -> dict[str, Any]:
        return {"weights": [list(r) for r in self.weights], "bias": list(self.bias)}

    def apply(self, probs: NDArray[np.floating]) -> NDArray[np.float32]:
        """(N, 4) probabilities -> (N, 4) adapted probabilities."""
        z = np.log(np.clip(np.asarray(probs, dtype=np.float64), _EPS, 1.0))
        logits = z @ np.asarray(self.weights).T + np.asarray(self.bias)
        logits -= logits.max(axis=1, keepdims=True)
        e = np.exp(logits)
        return (e / e.sum(axis=1, keepdims=True)).astype(np.float32)


class AdaptableSession:
    """An onnxruntime session whose class probabilities pass through an :class:`OutputAdaptation`
    (or not, when it is None); everything else is the session's own (a start head's output too:
    the adaptation is fitted on the full-body network's)."""

    def __init__(self, session: Any, adaptation: OutputAdaptation | None = None) -> None:
        self._session = session
        self.adaptation = adaptation

    def set_adaptation(self, adaptation: OutputAdaptation | None) -> None:
        self.adaptation = adaptation  # one reference assignment: the next run uses it

    def run(self, output_names: Any, feeds: dict[str, Any]) -> list[Any]:
        out = list(self._session.run(output_names, feeds))
        adaptation = self.adaptation
        if adaptation is not None and out:
            out[0] = adaptation.apply(out[0])
        return out

    def __getattr__(self, name: str) -> Any:  # get_inputs, get_outputs, get_modelmeta ...
        return getattr(self._session, name)


# ------------------------------------------------------------------------------------------ fit
def _softmax(x: NDArray[np.float64]) -> NDArray[np.float64]:
    x = x - x.max(axis=1, keepdims=True)
    e = np.exp(x)
    out: NDArray[np.float64] = e / e.sum(axis=1, keepdims=True)
    return out


def fit_affine(probs: NDArray[np.floating], labels: NDArray[np.int64], l2: float = 0.1) -> OutputAdaptation:
    """The affine map of log-probabilities that best fits ``labels`` (class-balanced cross-entropy
    + ``l2`` x (|W - I|^2 + |b|^2)); frames labelled ignore (-1) are left out."""
    from scipy.optimize import minimize

    keep = labels >= 0
    z = np.log(np.clip(np.asarray(probs, dtype=np.float64)[keep], _EPS, 1.0))
    y = labels[keep]
    if len(y) == 0:
        raise InputError("no labelled frames to adapt on")
    counts = np.bincount(y, minlength=_K).astype(np.float64)
    class_w = np.where(counts > 0, 1.0 / np.maximum(counts, 1.0), 0.0)
    w = class_w[y] / class_w[y].sum()
    onehot = np.eye(_K)[y]
    eye = np.eye(_K)

    def loss(theta: NDArray[np.float64]) -> tuple[float, NDArray[np.float64]]:
        W, b = theta[: _K * _K].reshape(_K, _K), theta[_K * _K :]
        q = _softmax(z @ W.T + b)
        ce = -float(np.sum(w * np.log(np.clip((q * onehot).sum(1), 1e-12, 1.0))))
        g = (q - onehot) * w[:, None]  # d CE / d logits
        gW = g.T @ z + 2 * l2 * (W - eye)
        gb = g.sum(0) + 2 * l2 * b
        reg = l2 * (float(np.sum((W - eye) ** 2)) + float(np.sum(b**2)))
        return ce + reg, np.concatenate([gW.ravel(), gb])

    theta0 = np.concatenate([eye.ravel(), np.zeros(_K)])
    res = minimize(loss, theta0, jac=True, method="L-BFGS-B", options={"maxiter": 300})
    theta = res.x if np.isfinite(res.x).all() else theta0
    return OutputAdaptation.from_arrays(theta[: _K * _K].reshape(_K, _K), theta[_K * _K :])


@dataclass(frozen=True, slots=True)
class TeachResult:
    """A fitted adaptation and what it does on the held-back part of the teach take.

    before / after: the streaming recogniser's frame accuracy (and macro-F1) on the held-back frames
    with the model alone / adapted; split_s: where the held-back part starts (seconds into the take).
    """

    adaptation: OutputAdaptation
    before: dict[str, Any]
    after: dict[str, Any]
    split_s: float
    fit_frames: int
    holdout_frames: int

    @property
    def helps(self) -> bool:
        a, b = self.after.get("accuracy"), self.before.get("accuracy")
        return a is not None and b is not None and a >= b

    def report(self) -> dict[str, Any]:
        return {
            "method": METHOD,
            "before": self.before,
            "after": self.after,
            "split_s": self.split_s,
            "fit_frames": self.fit_frames,
            "holdout_frames": self.holdout_frames,
            "helps": self.helps,
        }


def _figures(seq: LabelledSequence, pred: NDArray[np.int64]) -> dict[str, Any]:
    ev = evaluate([scored(seq, pred)])
    return {
        "accuracy": ev.accuracy,
        "macro_f1": ev.macro_f1,
        "frames": ev.frames,
        "false_movement": ev.overall.false_movement,
        "confusion": ev.confusion.tolist(),
    }


def adapted_trace(trace: NetworkTrace, adaptation: OutputAdaptation | None) -> NetworkTrace:
    return trace if adaptation is None else replace(trace, raw=adaptation.apply(trace.raw))


def score_sequence(
    session: Any, seq: LabelledSequence, config: RecognizerConfig, adaptation: OutputAdaptation | None = None
) -> dict[str, Any]:
    """The streaming recogniser's figures on a labelled sequence, with or without an adaptation."""
    r = corpus.resample(seq, model_info(session).fps)
    trace = network_trace(session, r.joints_m, r.fps)
    return _figures(r, replay(adapted_trace(trace, adaptation), config))


def fit_adaptation(
    session: Any,
    seq: LabelledSequence,
    config: RecognizerConfig,
    holdout_fraction: float = 0.34,
    l2: float = 0.1,
) -> TeachResult:
    """Fit the participant's adaptation on the first part of the teach take ``seq`` and score it,
    with the model alone, on the held-back last ``holdout_fraction`` (the recogniser streams the
    whole take; only the held-back frames are scored)."""
    if not 0.1 <= holdout_fraction <= 0.6:
        raise InputError(f"holdout_fraction must be in [0.1, 0.6], got {holdout_fraction}")
    r = corpus.resample(seq, model_info(session).fps)
    n = len(r)
    split = math.floor(n * (1.0 - holdout_fraction))
    fit_labels = r.labels.copy()
    fit_labels[split:] = IGNORE_INDEX
    held = r.labels.copy()
    held[:split] = IGNORE_INDEX
    for part, name in ((fit_labels, "teaching"), (held, "held-back")):
        present = set(np.unique(part[part >= 0]).tolist())
        if len(present) < 2:
            raise InputError(
                f"the {name} part of the take has {len(present)} labelled action(s); a teach take needs "
                "still and at least one movement in both parts (record it with the teach protocol)"
            )
    trace = network_trace(session, r.joints_m, r.fps)
    adaptation = fit_affine(trace.raw, fit_labels, l2)
    held_seq = LabelledSequence(r.joints_m, r.fps, held, r.tags, None, r.source, r.name)
    before = _figures(held_seq, replay(trace, config))
    after = _figures(held_seq, replay(adapted_trace(trace, adaptation), config))
    return TeachResult(
        adaptation,
        before,
        after,
        round(split / r.fps, 3),
        int(np.sum(fit_labels >= 0)),
        int(np.sum(held >= 0)),
    )
