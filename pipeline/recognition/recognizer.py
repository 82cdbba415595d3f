"""Streaming action recognition: one model call per new frame on a sliding window.

:class:`ActionRecognizer` receives the navigator's 3D skeleton frame by frame
(any frame rate, NaN for unknown joints), resamples it to the model's frame rate,
runs the committed SlowFast ONNX model on the newest window, smooths the class
probabilities with an exponential moving average (as in the paper) and only
changes the command when a new class leads with a clearly higher smoothed
probability than the switching threshold (hysteresis: the current command holds
while a challenger is between 0.5 and ``switch_prob``), optionally for a minimum
dwell time, so the command does not flicker. A model with a start head (a second output,
``scripts/combine_action.py``) has that output smoothed alike for the bout gate, which reads it
while no bout is on. It also reports the smoothed facing direction and the intended walking
speed. onnxruntime only; no torch.

Timestamps must increase strictly; a frame with an equal or earlier timestamp, or
a wrong shape, raises :class:`InputError` and changes nothing. A gap longer than
``max_gap_s`` starts afresh (as :meth:`ActionRecognizer.reset`). Non-finite
coordinates (NaN, inf) are unknown; a frame without any known leg joint (hips,
knees, ankles) is no data and counts as a gap: shorter than ``max_gap_s`` the
command holds, longer (or before any data) it is ``still`` with confidence 0 and
``no_data`` set, and a warning is logged once per such stretch. When data comes back
within ``max_gap_s``, the model frames of the stretch glide from the last frame with data
to the new one; a joint that the last frame put off its path (more than ``_BRIDGE_OUTLIER_M``
from both its previous point and where it was heading: a single-frame outlier) glides from
its previous point instead.
"""

from __future__ import annotations

import logging
import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError, ModelError
from pipeline.recognition.bout import BoutGate, GateConfig, GateVerdict
from pipeline.recognition.features import (
    EVIDENCE_CHANNELS,
    FEATURE_CHANNELS,
    FEATURES_V1,
    WITH_EVIDENCE,
    FeatureWindow,
    RingWindow,
    evidence_vector,
    model_input,
    window_features,
)
from pipeline.recognition.orientation import YawSmoother, raw_yaw_deg
from pipeline.recognition.speed import SpeedConfig, gap_filled, leg_heights, speed_from_heights
from pipeline.recognition.steps import StepConfig, StepFrame, StepTracker
from pipeline.recognition.types import ActionEstimate
from pipeline.skeleton import ACTIONS, NUM_JOINTS, J

log = logging.getLogger(__name__)

DEFAULT_MODEL_PATH = Path(__file__).resolve().parent / "action.onnx"
_STILL = ACTIONS.index("still")
_LEG_JOINTS = [J[n] for n in ("l_hip", "r_hip", "l_knee", "r_knee", "l_ankle", "r_ankle")]


@dataclass(frozen=True, slots=True)
class RecognizerConfig:
    """Parameters of the streaming recogniser (the settings' ``[recognition]``).

    ema_alpha: weight of a new model output in the probability EMA, per model frame.
    min_dwell_s: how long a new class must lead (with probability >= switch_prob) before the
        command changes; stop_dwell_s: the same for a change to ``still``.
    yaw_alpha: weight of a new frame in the facing-direction EMA, per model frame.
    max_gap_s: a longer gap between frames starts afresh (reset).
    speed_alpha: weight of a new estimate in the speed EMA, per model frame.
    model_path: the action model ONNX (default: the committed one).
    threads: onnxruntime intra-op threads (0 = its choice).
    gate: the stepping-bout gate on the step evidence (no movement without a step; one command
        per bout); off = the network's EMA + hysteresis alone (MODEL_CARD.md).
    """

    model_path: Path = DEFAULT_MODEL_PATH
    ema_alpha: float = 0.5
    min_dwell_s: float = 0.0
    stop_dwell_s: float = 0.0
    switch_prob: float = 0.6
    yaw_alpha: float = 0.3
    max_gap_s: float = 0.5
    speed_alpha: float = 0.15
    speed: SpeedConfig = field(default_factory=SpeedConfig)
    threads: int = 1
    gate: bool = True
    gate_config: GateConfig = field(default_factory=GateConfig)
    steps: StepConfig = field(default_factory=StepConfig)

    def __post_init__(self) -> None:
        for name in ("ema_alpha", "yaw_alpha", "speed_alpha"):
            value = getattr(self, name)
            if not 0 < value <= 1:
                raise ValueError(f"{name} must be in (0, 1], got {value}")
        if self.min_dwell_s < 0 or self.stop_dwell_s < 0:
            raise ValueError(
                f"min_dwell_s and stop_dwell_s must be >= 0, got {self.min_dwell_s}, {self.stop_dwell_s}"
            )
        if not 0 <= self.switch_prob <= 1:
            raise ValueError(f"switch_prob must be in [0, 1], got {self.switch_prob}")
        if self.max_gap_s <= 0:
            raise ValueError(f"max_gap_s must be positive, got {self.max_gap_s}")
        if self.threads < 0:
            raise ValueError(f"threads must be >= 0, got {self.threads}")


@dataclass(frozen=True, slots=True)
class ModelInfo:
    """What the ONNX file says about itself (its metadata).

    features: the input it expects: ``v1`` joints only (17 x 7 channels), ``v2`` joints and the
    step evidence (17 x 7 + 16 channels, :func:`features.evidence_vector`), ``v3`` the same with
    the arms and the face masked out (:data:`features.V3_JOINTS`).
    start_head: the file has a second output, the legs-only start head's probabilities (the bout
    gate's second judge while no bout is on; ``scripts/combine_action.py``).
    """

    window: int
    fps: float
    classes: tuple[str, ...]
    input_name: str
    features: str = FEATURES_V1
    start_head: bool = False


def open_session(path: Path, threads: int = 1) -> Any:
    """An onnxruntime session for the action model; :class:`ModelError` if it cannot be loaded."""
    import onnxruntime as ort

    p = Path(path)
    if not p.is_file():
        raise ModelError(f"action model not found: {p} (train it with scripts/train_action.py)")
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = threads
    opts.inter_op_num_threads = 1
    opts.log_severity_level = 3
    try:
        return ort.InferenceSession(str(p), sess_options=opts, providers=["CPUExecutionProvider"])
    except Exception as exc:  # onnxruntime raises its own Fail/InvalidGraph types
        raise ModelError(f"cannot load action model {p}: {exc}") from exc


def model_info(session: Any) -> ModelInfo:
    """Read window length, frame rate and classes from the model; :class:`ModelError` if unusable."""
    meta = session.get_modelmeta().custom_metadata_map
    inputs = session.get_inputs()
    try:
        window = int(meta["window"])
        fps = float(meta["fps"])
        classes = tuple(meta["classes"].split(","))
    except (KeyError, ValueError) as exc:
        raise ModelError(f"the action model lacks its metadata (window, fps, classes): {exc}") from exc
    if classes != ACTIONS:
        raise ModelError(f"the action model's classes must be {ACTIONS}, got {classes}")
    features = meta.get("features", FEATURES_V1)
    if features not in FEATURE_CHANNELS:
        raise ModelError(
            f"the action model expects features {features!r}; "
            f"this recogniser makes {', '.join(FEATURE_CHANNELS)}"
        )
    channels = FEATURE_CHANNELS[features]
    shape = inputs[0].shape if len(inputs) == 1 else None
    if shape is None or len(shape) != 3 or shape[1] != channels or shape[2] != window:
        raise ModelError(
            f"the action model's input must be (B, {channels}, {window}) for features {features}, got {shape}"
        )
    outputs = session.get_outputs()
    if not 1 <= len(outputs) <= 2 or any(len(o.shape) != 2 or o.shape[1] != len(ACTIONS) for o in outputs):
        raise ModelError(
            f"the action model must have one output (B, {len(ACTIONS)}) (and a start head alike), "
            f"got {[o.shape for o in outputs]}"
        )
    return ModelInfo(
        window=window,
        fps=fps,
        classes=classes,
        input_name=inputs[0].name,
        features=features,
        start_head=len(outputs) == 2,
    )


def classify_windows(
    session: Any, windows: NDArray[np.floating], fps: float, evidence: NDArray[np.floating] | None = None
) -> NDArray[np.float32]:
    """Class probabilities (N, 4) of windows (N, T, 17, 3) in one batched model call; a ``v2`` or
    ``v3`` model also needs the windows' step evidence (N, T, 16)."""
    return classify_windows_heads(session, windows, fps, evidence)[0]


def classify_windows_heads(
    session: Any, windows: NDArray[np.floating], fps: float, evidence: NDArray[np.floating] | None = None
) -> tuple[NDArray[np.float32], NDArray[np.float32] | None]:
    """:func:`classify_windows` and the start head's probabilities (N, 4) (None without one)."""
    info = model_info(session)
    feats = window_features(windows, fps)
    if info.features in WITH_EVIDENCE and evidence is None:
        raise ModelError(
            f"this action model (features {info.features}) needs the step evidence of each window"
        )
    x = model_input(feats, None if evidence is None else np.asarray(evidence, np.float32), info.features)
    outs = session.run(None, {info.input_name: x})
    start = np.asarray(outs[1], dtype=np.float32) if info.start_head else None
    return np.asarray(outs[0], dtype=np.float32), start


def ema(
    previous: NDArray[np.floating] | None, value: NDArray[np.floating], alpha: float
) -> NDArray[np.float64]:
    """One exponential-moving-average step: alpha x value + (1 - alpha) x previous."""
    v = np.asarray(value, dtype=np.float64)
    if previous is None:
        return v
    return alpha * v + (1.0 - alpha) * np.asarray(previous, dtype=np.float64)


_BRIDGE_OUTLIER_M = 0.1  # a joint this far off both its previous point and their path is an outlier


def _without_outliers(recent: deque[NDArray[np.float64]]) -> NDArray[np.float64]:
    """The newest of ``recent`` (the last three frames with data) with each joint that lies more than
    ``_BRIDGE_OUTLIER_M`` both from its previous point and from where its two previous points were
    heading (a moving foot is where it was heading; an outlier is off its path) put back at its
    previous point."""
    last = recent[-1]
    if len(recent) < 3:
        return last
    before, prev = recent[0], recent[1]
    off = (np.linalg.norm(last - prev, axis=1) > _BRIDGE_OUTLIER_M) & (
        np.linalg.norm(last - (2.0 * prev - before), axis=1) > _BRIDGE_OUTLIER_M
    )  # NaN compares False: kept
    out = last.copy()
    out[off] = prev[off]
    return out


def _interpolate(a: NDArray[np.float64], b: NDArray[np.float64], w: float) -> NDArray[np.float64]:
    """Linear interpolation a -> b at w in [0, 1]; where one side is unknown, the nearer frame's value."""
    lin = (1.0 - w) * a + w * b
    nearest = a if w < 0.5 else b
    return np.where(np.isnan(a) | np.isnan(b), nearest, lin)


class CommandFilter:
    """EMA over class probabilities plus hysteresis: the command changes only to a class that
    has led the smoothed probabilities, with at least ``switch_prob``, for ``min_dwell_s``
    (``stop_dwell_s`` for a change to ``still``: stopping late feels worse than starting late,
    so it may be shorter; None = ``min_dwell_s``).

    ``update(probs, t, ticks)`` takes one model output covering ``ticks`` model frames (the EMA
    weight is ``1 - (1 - ema_alpha) ** ticks``, so skipped frames count) and returns the
    command's class index. It starts at ``still``.
    """

    def __init__(
        self, ema_alpha: float, min_dwell_s: float, switch_prob: float, stop_dwell_s: float | None = None
    ) -> None:
        if not 0 < ema_alpha <= 1:
            raise ValueError(f"ema_alpha must be in (0, 1], got {ema_alpha}")
        stop = min_dwell_s if stop_dwell_s is None else stop_dwell_s
        if min_dwell_s < 0 or stop < 0 or not 0 <= switch_prob <= 1:
            raise ValueError(
                "expected min_dwell_s >= 0, stop_dwell_s >= 0 and switch_prob in [0, 1], got "
                f"{min_dwell_s}, {stop_dwell_s}, {switch_prob}"
            )
        self.ema_alpha = ema_alpha
        self.min_dwell_s = min_dwell_s
        self.stop_dwell_s = stop
        self.switch_prob = switch_prob
        self.reset()

    def reset(self) -> None:
        self._probs: NDArray[np.float64] | None = None
        self.label = _STILL
        self._candidate: int | None = None
        self._candidate_since = 0.0

    @property
    def probs(self) -> NDArray[np.float64]:
        """The smoothed probabilities (certainly ``still`` before the first update)."""
        return self._probs if self._probs is not None else np.eye(len(ACTIONS))[_STILL]

    def update(self, probs: NDArray[np.floating], timestamp_s: float, ticks: int = 1) -> int:
        p = np.asarray(probs, dtype=np.float64)
        if p.shape != (len(ACTIONS),) or not np.isfinite(p).all():
            raise ValueError(f"probs must be {len(ACTIONS)} finite numbers, got {p}")
        self._probs = ema(self._probs, p, 1.0 - (1.0 - self.ema_alpha) ** max(ticks, 1))
        best = int(np.argmax(self._probs))
        if best == self.label or self._probs[best] < self.switch_prob:
            self._candidate = None
            return self.label
        if self._candidate != best:
            self._candidate, self._candidate_since = best, timestamp_s
        dwell = self.stop_dwell_s if best == _STILL else self.min_dwell_s
        if timestamp_s - self._candidate_since >= dwell - 1e-9:
            self.label, self._candidate = best, None
        return self.label


class ActionRecognizer:
    """Streaming recogniser of the navigator's locomotion command (see the module docstring).

    With ``config.gate`` (the default) the command comes from the stepping-bout gate
    (:mod:`pipeline.recognition.bout`) on the step evidence (:mod:`pipeline.recognition.steps`)
    and the network's smoothed probabilities; without it, from the EMA + hysteresis filter alone
    (the paper's method, kept for the ablation). Each estimate carries the frame's step evidence
    and the gate's verdict (the dashboard's step strip).
    """

    def __init__(self, session: Any, config: RecognizerConfig) -> None:
        self._session = session
        self.config = config
        self.info = model_info(session)
        self._dt = 1.0 / self.info.fps
        history = max(self.info.window, round(2.5 * self.info.fps))
        self._legs: deque[tuple[float, float]] = deque(maxlen=history)  # the model frames' leg heights
        self._evidence = RingWindow(self.info.window, (EVIDENCE_CHANNELS,), np.float32)
        self._feature_window = FeatureWindow(self.info.window, self.info.fps)
        self._yaw = YawSmoother(alpha=config.yaw_alpha, rate_hz=self.info.fps)
        self._filter = CommandFilter(
            config.ema_alpha, config.min_dwell_s, config.switch_prob, config.stop_dwell_s
        )
        # the start head's probabilities, smoothed alike (only its EMA is read)
        self._start_filter = CommandFilter(
            config.ema_alpha, config.min_dwell_s, config.switch_prob, config.stop_dwell_s
        )
        steps = config.steps
        if abs(steps.rate_hz - self.info.fps) > 1e-9:
            from dataclasses import replace

            steps = replace(steps, rate_hz=self.info.fps)
        self._tracker = StepTracker(steps)
        self._gate = BoutGate(config.gate_config)
        self.reset()

    @classmethod
    def from_config(cls, config: RecognizerConfig) -> ActionRecognizer:
        """Load the ONNX model named in the config with onnxruntime."""
        return cls(open_session(config.model_path, config.threads), config)

    @property
    def session(self) -> Any:
        """The onnxruntime session (benchmarks time the bare model call with it)."""
        return self._session

    @property
    def fps(self) -> float:
        """The model's frame rate (input is resampled to it)."""
        return self.info.fps

    def reset(self) -> None:
        """Forget everything (a new navigator, or a long gap)."""
        self._input_t: float | None = None
        self._warned_no_data = False
        self._forget()

    def _forget(self) -> None:
        self._gap = False  # frames without data came since the newest frame with data ...
        self._recent: deque[NDArray[np.float64]] = deque(maxlen=3)  # ... and the last three with data
        self._legs.clear()
        self._feature_window.clear()
        self._evidence.clear()
        self._yaw.reset()
        self._last_t: float | None = None
        # model frame n is taken at tick0 + n / fps; the tracker, filter and gate count time from
        # tick0 (n / fps exactly, as in the replay of a recorded sequence: no summed drift, and
        # durations that are whole frames compare the same way on any clock)
        self._tick0, self._ticks = 0.0, 0  # model frames taken so far
        self._filter.reset()
        self._start_filter.reset()
        self._tracker.reset()
        self._gate.reset()
        self._pending: list[StepFrame] = []
        self._step_frame: StepFrame | None = None
        self._verdict: GateVerdict | None = None
        self._label = _STILL
        self._speed = 0.0
        self._moving_frames = 0

    def _no_data(self) -> ActionEstimate:
        return ActionEstimate(
            label="still", probs=dict.fromkeys(ACTIONS, 0.0), yaw_deg=self._yaw.yaw_deg, no_data=True
        )

    def _probs(self) -> NDArray[np.float64]:
        """The smoothed network probabilities; with the gate, the classes it rules out scaled by 0.1."""
        p = self._filter.probs.copy()
        if not self.config.gate:
            return p
        if self._label == _STILL:
            p[1:] *= 0.1
        else:
            p[_STILL] *= 0.1
        return p / p.sum()

    def _estimate(self) -> ActionEstimate:
        if self._last_t is None:
            return self._no_data()
        label = self._label
        return ActionEstimate(
            label=ACTIONS[label],
            probs=dict(zip(ACTIONS, self._probs().tolist(), strict=True)),
            yaw_deg=self._yaw.yaw_deg,
            speed_mps=self._speed if label != _STILL else 0.0,
            steps=self._step_frame,
            gate=self._verdict,
        )

    def update(self, joints_m: NDArray[np.floating], timestamp_s: float) -> ActionEstimate:
        """Add one skeleton (17, 3) metres (NaN = unknown) taken at ``timestamp_s``; the command now.

        Raises :class:`InputError` (and changes nothing) for a wrong shape or a timestamp
        that does not increase.
        """
        j = np.asarray(joints_m, dtype=np.float64)
        if j.shape != (NUM_JOINTS, 3):
            raise InputError(f"joints must have shape ({NUM_JOINTS}, 3), got {j.shape}")
        t = float(timestamp_s)
        if not math.isfinite(t):
            raise InputError(f"timestamp must be a finite number, got {timestamp_s}")
        if self._input_t is not None and t <= self._input_t:
            raise InputError(f"timestamps must increase: got {t} after {self._input_t}")
        self._input_t = t
        j = np.where(np.isfinite(j), j, np.nan)  # inf is unknown, like NaN
        if self._last_t is not None and t - self._last_t > self.config.max_gap_s:
            log.info("no skeleton for %.2f s: recogniser starts afresh", t - self._last_t)
            self._forget()
        if not np.isfinite(j[_LEG_JOINTS]).all(axis=1).any():  # no leg joint known: no data
            if self._last_t is None and not self._warned_no_data:
                log.warning("no known leg joint in the navigator's skeleton: still, confidence 0")
                self._warned_no_data = True
            self._gap = self._last_t is not None
            return self._estimate()  # holds within max_gap_s, no data after it
        self._warned_no_data = False

        ticks = 0
        if self._last_t is None or not self._recent:
            self._tick0, self._ticks = t, 1
            self._add_frame(j, 0.0)
            ticks = 1
        else:
            span = t - self._last_t
            # across a stretch without data the skeleton glides from the last frame with data, but a
            # joint that frame put far off its path starts from its previous point: a single-frame
            # outlier just before the stretch would otherwise become a smooth move the step tracker
            # takes for a step
            start = _without_outliers(self._recent) if self._gap else self._recent[-1]
            while (tick := self._tick0 + self._ticks * self._dt) <= t + 1e-9:
                w = (tick - self._last_t) / span
                # the clock of every model frame is k / fps, as training and the replay
                # (evaluation.step_frames) time the step tracker: k x (1 / fps) differs in the last
                # bit, and a swing exactly 3 frames long must be 0.1 s in all of them or in none
                frame = _interpolate(start, j, min(max(w, 0.0), 1.0))
                self._add_frame(frame, self._ticks / self.info.fps)
                self._ticks += 1
                ticks += 1
        self._last_t = t
        self._recent.append(j)
        self._gap = False
        self._yaw.update(raw_yaw_deg(j), t)
        if ticks:
            self._step(ticks)
        return self._estimate()

    def _add_frame(self, frame: NDArray[np.float64], tick_t: float) -> None:
        """One model frame (``tick_t``: seconds since the stream's first frame): kept for the window,
        and through the step tracker."""
        self._legs.append(leg_heights(frame))
        self._feature_window.push(frame)
        sf = self._tracker.update(frame, tick_t)
        self._pending.append(sf)
        self._evidence.push(evidence_vector(sf))

    def _model_input(self) -> NDArray[np.float32]:
        feats = self._feature_window.features()
        evidence = self._evidence.view() if self.info.features in WITH_EVIDENCE else None
        return model_input(feats, evidence, self.info.features)[None]

    def _step(self, ticks: int) -> None:
        x = self._model_input()
        outs = self._session.run(None, {self.info.input_name: x})
        out = np.asarray(outs[0][0], dtype=np.float64)
        label = self._filter.update(out, self._pending[-1].t, ticks)
        start = None
        if self.info.start_head:
            self._start_filter.update(np.asarray(outs[1][0], dtype=np.float64), self._pending[-1].t, ticks)
            start = self._start_filter.probs
        if self.config.gate:
            for sf in self._pending:
                self._verdict = self._gate.update(sf, self._filter.probs, sf.t, start)
            assert self._verdict is not None
            label = self._verdict.label
        self._step_frame = self._pending[-1]
        self._pending = []
        self._label = label
        if label == _STILL:
            self._speed, self._moving_frames = 0.0, 0
            return
        # cadence from the stepping since the user started moving, not the standing before
        self._moving_frames = min(self._moving_frames + ticks, len(self._legs))
        recent = list(self._legs)[-max(self._moving_frames, self.info.window) :]
        left, right = (gap_filled(np.array([h[k] for h in recent])) for k in (0, 1))
        raw = speed_from_heights(left, right, self.info.fps, ACTIONS[label], self.config.speed)
        w = 1.0 - (1.0 - self.config.speed_alpha) ** ticks
        self._speed = raw if self._speed == 0.0 else w * raw + (1.0 - w) * self._speed


def recognize_sequence(
    recognizer: ActionRecognizer,
    joints_m: NDArray[np.floating],
    fps: float,
    progress: Callable[[int], None] | None = None,
) -> list[ActionEstimate]:
    """Run the recogniser over a whole sequence (T, 17, 3) at ``fps``; one estimate per input frame.

    The recogniser is reset first; ``progress(n)`` is called with the number of frames done.
    """
    arr = np.asarray(joints_m, dtype=np.float64)
    if arr.ndim != 3 or arr.shape[1:] != (NUM_JOINTS, 3):
        raise InputError(f"joints must have shape (T, {NUM_JOINTS}, 3), got {arr.shape}")
    if not math.isfinite(fps) or fps <= 0:
        raise InputError(f"fps must be a positive number, got {fps}")
    recognizer.reset()
    out: list[ActionEstimate] = []
    for i, frame in enumerate(arr):
        out.append(recognizer.update(frame, i / fps))
        if progress is not None and (i + 1) % 100 == 0:
            progress(100)
    if progress is not None and len(out) % 100:
        progress(len(out) % 100)
    return out
