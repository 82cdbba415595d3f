"""The recogniser run over labelled sequences and scored: the code behind `cavewalk evaluate`
and the model card's figures (``scripts/eval_action.py``, ``scripts/loso_action.py``)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.recognition.bout import BoutGate, GateConfig
from pipeline.recognition.dataset import LabelledSequence
from pipeline.recognition.features import EVIDENCE_CHANNELS, WITH_EVIDENCE, evidence_vector
from pipeline.recognition.metrics import Evaluation, ScoredSequence, evaluate
from pipeline.recognition.recognizer import (
    ActionRecognizer,
    CommandFilter,
    RecognizerConfig,
    classify_windows_heads,
    model_info,
    recognize_sequence,
)
from pipeline.recognition.steps import StepConfig, StepFrame, StepTracker
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


# ---------------------------------------------------------------- fast replay (tuning and the ablations)
# The streaming recogniser at the model's own frame rate is: per frame, the step tracker, the model
# on the newest window, the EMA (+ hysteresis), the gate. With the model's outputs computed once in
# batches, the rest replays in microseconds per frame, so settings and ablations are cheap to try.
# test_evaluation.py checks that the replay gives the streaming recogniser's commands.


@dataclass(frozen=True, slots=True)
class NetworkTrace:
    """What the network and the step tracker make of one sequence at the model's frame rate.

    raw: (T, 4) model outputs for the window ending at each frame; steps: per-frame step evidence;
    start: (T, 4) the start head's outputs (None: the model has none).
    """

    raw: NDArray[np.float32]
    steps: tuple[StepFrame, ...]
    start: NDArray[np.float32] | None = None


def step_frames(
    joints_m: NDArray[np.floating], fps: float, steps: StepConfig | None = None
) -> tuple[StepFrame, ...]:
    """The run-time step tracker over a whole sequence."""
    j = np.where(np.isfinite(joints_m), joints_m, np.nan).astype(np.float64)
    tracker = StepTracker(replace(steps or StepConfig(), rate_hz=fps))
    return tuple(tracker.update(f, i / fps) for i, f in enumerate(j))


def network_trace(
    session: Any,
    joints_m: NDArray[np.floating],
    fps: float,
    steps: StepConfig | None = None,
    batch: int = 512,
    frames: tuple[StepFrame, ...] | None = None,
) -> NetworkTrace:
    """Model outputs and step evidence for every frame of a sequence recorded at the model's rate
    (``frames``: the sequence's step frames when already computed)."""
    info = model_info(session)
    if abs(fps - info.fps) > 1e-6:
        raise ValueError(f"the sequence is at {fps:g} fps; resample it to the model's {info.fps:g} fps first")
    j = np.where(np.isfinite(joints_m), joints_m, np.nan).astype(np.float64)
    if frames is None:
        frames = step_frames(j, fps, steps)
    ev = (
        np.stack([evidence_vector(f) for f in frames])
        if frames
        else np.zeros((0, EVIDENCE_CHANNELS), np.float32)
    )
    n, w = len(j), info.window
    idx = np.maximum(np.arange(n)[:, None] - np.arange(w - 1, -1, -1)[None, :], 0)
    out, start = [np.zeros((0, 4), np.float32)], [np.zeros((0, 4), np.float32)]
    for a in range(0, n, batch):
        sel = idx[a : a + batch]
        evidence = ev[sel] if info.features in WITH_EVIDENCE else None
        probs, head = classify_windows_heads(session, j[sel], fps, evidence)
        out.append(probs)
        if head is not None:
            start.append(head)
    raw = np.concatenate(out).astype(np.float32)
    return NetworkTrace(raw, frames, np.concatenate(start).astype(np.float32) if info.start_head else None)


def replay(trace: NetworkTrace, config: RecognizerConfig) -> NDArray[np.int64]:
    """The recogniser's command per frame from a trace (same EMA, hysteresis and gate settings)."""
    filt = CommandFilter(config.ema_alpha, config.min_dwell_s, config.switch_prob, config.stop_dwell_s)
    start = CommandFilter(config.ema_alpha, config.min_dwell_s, config.switch_prob, config.stop_dwell_s)
    gate = BoutGate(config.gate_config)
    out = np.empty(len(trace.raw), dtype=np.int64)
    for i, (p, sf) in enumerate(zip(trace.raw, trace.steps, strict=True)):
        label = filt.update(p, sf.t)
        head = None
        if trace.start is not None:
            start.update(trace.start[i], sf.t)
            head = start.probs
        if config.gate:
            label = gate.update(sf, filt.probs, sf.t, head).label
        out[i] = label
    return out


# ---------------------------------------------------------------- choosing the gate's settings

GATE_GRID: dict[str, tuple[float | str, ...]] = {
    "rhythm": ("max", "median"),
    "start_prob": (0.4, 0.6),
    "pause_still_prob": (0.75, 0.9, 1.0),
    "pause_gain": (1.0, 1.15),
    "pause_margin_s": (0.1, 0.2),
}


def objective(ev: Evaluation) -> float:
    """What the gate's settings are chosen for (issue 14's behaviour): accuracy and macro-F1, with
    penalties for false movement above 1 %, start and stop (beyond the rhythm's pause) later than
    300 ms at the median, and flicker."""
    acc, f1 = ev.accuracy or 0.0, ev.macro_f1 or 0.0
    fm = ev.overall.false_movement or 0.0
    start = ev.start.median_s if ev.start.median_s is not None else 1.0
    stop = ev.stop_beyond_rhythm.median_s if ev.stop_beyond_rhythm.median_s is not None else 1.0
    flicker = ev.flicker or 1.0
    return (
        acc + f1 - 5.0 * max(0.0, fm - 0.01) - 0.5 * max(0.0, start - 0.3) - 0.5 * max(0.0, stop - 0.3)
        - 0.02 * max(0.0, flicker - 1.0)
    )  # fmt: skip


def tune_gate(
    traces: Sequence[NetworkTrace],
    sequences: Sequence[LabelledSequence],
    base: RecognizerConfig,
    grid: dict[str, tuple[float | str, ...]] | None = None,
) -> tuple[GateConfig, list[tuple[dict[str, float | str], float]]]:
    """The grid point of gate settings with the best :func:`objective` on (tuning) sequences."""
    import itertools

    grid = grid or GATE_GRID
    keys = list(grid)
    table: list[tuple[dict[str, float | str], float]] = []
    best: tuple[float, GateConfig] | None = None
    for values in itertools.product(*(grid[k] for k in keys)):
        point = dict(zip(keys, values, strict=True))
        gate = replace(base.gate_config, **point)  # type: ignore[arg-type]
        config = replace(base, gate=True, gate_config=gate)
        scored_seqs = [scored(s, replay(t, config)) for s, t in zip(sequences, traces, strict=True)]
        value = objective(evaluate(scored_seqs))
        table.append((point, value))
        if best is None or value > best[0]:
            best = (value, gate)
    assert best is not None
    return best[1], table
