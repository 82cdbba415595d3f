"""The recogniser run over labelled sequences and scored: the code behind `cavewalk evaluate`
and the model card's figures (``scripts/eval_action.py``, ``scripts/loso_action.py``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from pipeline.recognition.dataset import LabelledSequence
from pipeline.recognition.metrics import Evaluation, ScoredSequence, evaluate
from pipeline.recognition.recognizer import ActionRecognizer, recognize_sequence
from pipeline.skeleton import ACTIONS


def predict(recognizer: ActionRecognizer, seq: LabelledSequence) -> NDArray[np.int64]:
    """The recogniser's command (class index) for every frame of ``seq``, streamed from a reset."""
    estimates = recognize_sequence(recognizer, seq.joints_m, seq.fps)
    return np.array([ACTIONS.index(e.label) for e in estimates], dtype=np.int64)


def scored(seq: LabelledSequence, pred: NDArray[np.int64]) -> ScoredSequence:
    return ScoredSequence(seq.name, seq.source, seq.labels, pred, seq.tags, seq.fps, seq.contacts)


def evaluate_recognizer(
    recognizer: ActionRecognizer,
    sequences: Sequence[LabelledSequence],
    exclude_s: float = 0.3,
    progress: Callable[[LabelledSequence], None] | None = None,
) -> Evaluation:
    """Stream every sequence through ``recognizer`` and score the commands against the labels."""
    out = []
    for seq in sequences:
        out.append(scored(seq, predict(recognizer, seq)))
        if progress is not None:
            progress(seq)
    return evaluate(out, exclude_s)
