"""Training of the skeleton SlowFast action model on simulated users (torch; the ``train`` extra).

Data: random routines from the simulator (``pipeline.sim``): random bodies, cadence,
knee lift, step width, facing direction, gestures, weight shifts, turning on the
spot and transitions at any moment. Each clean 3D sequence is seen by four
virtual cameras above the walls; the projected 2D joints get pixel noise
(white and slowly drifting, per camera), outliers and dropped joints, and are
triangulated back with the triangulation stage's own weighted DLT
(``pipeline.triangulation.dlt``), so the training skeletons carry the errors a
real CAVE produces (fewer than two views = unknown joint, NaN). On top come
whole-body gaps (everyone occluded for a moment) and body parts lost for a while
(the face, an arm, the wrists; sometimes the face for a whole routine).

Each epoch draws random windows of ``window`` frames (any frame can end one; frames
before a routine's start repeat its first frame, as in streaming), labelled with
their last frame's label (the streaming recogniser classifies the newest frame);
the 0.5 s after each true transition weigh double in the loss.
Everything is deterministic for a seed. The model is exported to ONNX with a
softmax output and metadata (window, fps, classes) that the recogniser reads.
"""

from __future__ import annotations

import hashlib
import json
import logging
import time
import warnings
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import look_at
from pipeline.recognition.dataset import LabelledSequence
from pipeline.recognition.features import (
    EVIDENCE_CHANNELS,
    FEATURE_CHANNELS,
    FEATURES_V1,
    FEATURES_V2,
    WITH_EVIDENCE,
    evidence_vector,
    model_input,
    window_features,
)
from pipeline.recognition.steps import StepConfig, StepTracker
from pipeline.sim.body import sample_body
from pipeline.sim.motion import simulate_user
from pipeline.sim.script import random_script
from pipeline.skeleton import ACTIONS, NUM_JOINTS, J
from pipeline.triangulation.dlt import triangulate_linear

log = logging.getLogger(__name__)

LABEL_INDEX = {name: i for i, name in enumerate(ACTIONS)}
# Joint groups that go missing together: face, left arm, right arm, both wrists.
_GROUPS: tuple[list[int], ...] = ([0, 1, 2, 3, 4], [7, 9], [8, 10], [9, 10])


@dataclass(frozen=True, slots=True)
class NoiseConfig:
    """Measurement faults of the simulated capture (per sequence, drawn uniformly in the ranges)."""

    pixel_sigma_px: tuple[float, float] = (1.0, 6.0)
    drift_sigma_px: tuple[float, float] = (0.0, 4.0)
    drop_prob: tuple[float, float] = (0.0, 0.25)
    outlier_prob: float = 0.01
    outlier_px: float = 60.0
    gap_prob_per_s: float = 0.05
    group_drop_per_s: float = 0.03  # a body part (face, an arm, the wrists) unknown for 0.5-6 s
    face_missing_prob: float = 0.05  # no face at all in the whole routine
    focal_px: float = 1000.0
    camera_height_m: float = 2.4
    camera_distance_m: float = 1.7


@dataclass(frozen=True, slots=True)
class DataConfig:
    """How many simulated routines, how long, and at which frame rate."""

    sequences: int = 360
    duration_s: float = 40.0
    fps: float = 30.0
    seed: int = 0
    start_radius_m: float = 0.7
    noise: NoiseConfig = field(default_factory=NoiseConfig)

    def cache_key(self) -> str:
        text = json.dumps(asdict(self), sort_keys=True)
        return hashlib.sha1(text.encode()).hexdigest()[:12]


@dataclass(frozen=True, slots=True)
class TrainConfig:
    """Optimisation settings."""

    window: int = 32
    epochs: int = 20
    windows_per_epoch: int = 60_000
    batch_size: int = 256
    lr: float = 3e-3
    weight_decay: float = 1e-3
    label_smoothing: float = 0.05
    slow_channels: int = 64
    fast_pathway: bool = True
    alpha: int = 4
    seed: int = 0
    threads: int = 1
    validation_fraction: float = 0.1
    transition_weight: float = 2.0  # loss weight of frames shortly after a true label change
    transition_window_s: float = 0.5
    features: str = FEATURES_V2  # v1: joints only; v2: joints + step evidence
    source_power: float = 0.5  # sampling: each source weighs (its frames) ** power
    augment: bool = False  # window augmentation (:func:`augment_windows`): speed, proportions, dropout
    augment_share: float = 1.0  # with ``augment``, the share of the windows augmented
    arms_still: float = 0.0  # share of the stepping windows whose arms hang still (:func:`still_arms`)

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.windows_per_epoch < self.batch_size:
            raise ValueError(
                "epochs and batch_size must be at least 1 and windows_per_epoch at least one batch "
                f"({self.batch_size}); got {self.epochs}, {self.batch_size}, {self.windows_per_epoch}"
            )
        if not 0.0 <= self.arms_still <= 1.0:
            raise ValueError(f"arms_still is a share of the stepping windows, 0 to 1; got {self.arms_still}")
        if not 0.0 <= self.augment_share <= 1.0:
            raise ValueError(f"augment_share is a share of the windows, 0 to 1; got {self.augment_share}")


@dataclass(frozen=True, slots=True)
class AugmentConfig:
    """Per-window augmentation of the training windows (:func:`augment_windows`), drawn uniformly.

    speed: the window is read at this many source frames per model frame (a slower or brisker
        version of the same movement; the step-evidence channels are read at the same frames).
    leg_scale: the legs (hips to ankles) relative to the trunk (other body proportions).
    step_scale: the feet's height above their lowest point in the window (a lower or higher step).
    drop_prob: chance of a window losing ``drop_joints`` random joints for its whole length.
    jitter_m: extra per-frame joint noise (metres, sigma).
    share: the share of the windows augmented; the others are read as recorded.
    """

    speed: tuple[float, float] = (0.75, 1.3)
    leg_scale: tuple[float, float] = (0.9, 1.1)
    step_scale: tuple[float, float] = (0.7, 1.3)
    drop_prob: float = 0.3
    drop_joints: tuple[int, int] = (1, 4)
    jitter_m: tuple[float, float] = (0.0, 0.01)
    share: float = 1.0

    def __post_init__(self) -> None:
        if not 0.0 <= self.share <= 1.0:
            raise ValueError(f"share is the share of the windows augmented, 0 to 1; got {self.share}")


@dataclass(frozen=True, slots=True)
class Dataset:
    """Concatenated sequences: joints (N, 17, 3) NaN = unknown, labels (N,) int (-1 = ignore, never a
    training target), starts (S + 1,) offsets; optional evidence (N, 14) step-evidence channels (made
    by the same step tracker as at run time) and sources (S,) the source of each sequence."""

    joints: NDArray[np.float32]
    labels: NDArray[np.int64]
    starts: NDArray[np.int64]
    fps: float
    evidence: NDArray[np.float32] | None = None
    sources: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.joints.shape[0] != self.labels.shape[0] or self.starts[-1] != self.labels.shape[0]:
            raise ValueError(
                f"joints {self.joints.shape}, labels {self.labels.shape} and starts end "
                f"{self.starts[-1]} disagree"
            )
        if self.evidence is not None and self.evidence.shape != (self.labels.shape[0], EVIDENCE_CHANNELS):
            raise ValueError(
                f"evidence must be ({self.labels.shape[0]}, {EVIDENCE_CHANNELS}), got {self.evidence.shape}"
            )
        if self.sources and len(self.sources) != self.num_sequences:
            raise ValueError(f"sources names {len(self.sources)} sequences of {self.num_sequences}")

    @property
    def num_sequences(self) -> int:
        return len(self.starts) - 1

    def subset(self, seqs: NDArray[np.int64]) -> Dataset:
        parts = [slice(int(self.starts[s]), int(self.starts[s + 1])) for s in seqs]
        lengths = np.array([p.stop - p.start for p in parts], dtype=np.int64)
        return Dataset(
            np.concatenate([self.joints[p] for p in parts]),
            np.concatenate([self.labels[p] for p in parts]),
            np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
            self.fps,
            None if self.evidence is None else np.concatenate([self.evidence[p] for p in parts]),
            tuple(self.sources[int(s)] for s in seqs) if self.sources else (),
        )

    def frame_sources(self) -> NDArray[np.str_]:
        """(N,) the source of every frame."""
        lengths = np.diff(self.starts)
        names = self.sources or ("",) * self.num_sequences
        return np.repeat(np.asarray(names, dtype=str), lengths)


# ---------------------------------------------------------------- capture noise


def cave_rig(noise: NoiseConfig) -> NDArray[np.float64]:
    """(4, 3, 4) world-to-camera [R | t] of one camera above each wall looking at the centre."""
    d, h = noise.camera_distance_m, noise.camera_height_m
    eyes = [(0.0, d, h), (d, 0.0, h), (0.0, -d, h), (-d, 0.0, h)]
    mats = []
    for eye in eyes:
        R, t = look_at(np.array(eye), np.array([0.0, 0.0, 1.0]))
        mats.append(np.hstack([R, t[:, None]]))
    return np.stack(mats)


def _drift(rng: np.random.Generator, shape: tuple[int, ...], sigma: float, frames_corr: float) -> NDArray:
    """AR(1) noise along axis 1 (time) with stationary std ``sigma``."""
    a = float(np.exp(-1.0 / frames_corr))
    eps = rng.normal(0.0, sigma * np.sqrt(1 - a * a), shape)
    out = np.empty(shape)
    out[:, 0] = rng.normal(0.0, sigma, (shape[0], *shape[2:]))
    for i in range(1, shape[1]):
        out[:, i] = a * out[:, i - 1] + eps[:, i]
    return out


def capture(
    joints_m: NDArray[np.floating], rng: np.random.Generator, noise: NoiseConfig, fps: float
) -> NDArray[np.float64]:
    """Clean (T, 17, 3) -> what the CAVE measures: 2D noise through DLT triangulation, NaN gaps."""
    clean = np.asarray(joints_m, dtype=np.float64)
    t = clean.shape[0]
    rt = cave_rig(noise)
    c = rt.shape[0]
    pts = clean.reshape(-1, 3)
    cam = np.einsum("cij,nj->cni", rt[:, :, :3], pts) + rt[:, None, :, 3]  # (C, N, 3)
    xy = cam[..., :2] / cam[..., 2:3]
    sigma = rng.uniform(*noise.pixel_sigma_px) / noise.focal_px
    drift = rng.uniform(*noise.drift_sigma_px) / noise.focal_px
    xy = xy + rng.normal(0.0, sigma, xy.shape)
    if drift > 0:
        d = _drift(rng, (c, t, 17, 2), drift, frames_corr=0.5 * fps)
        xy = xy + d.reshape(c, -1, 2)
    outliers = rng.random(xy.shape[:2]) < noise.outlier_prob
    xy[outliers] += rng.normal(0.0, noise.outlier_px / noise.focal_px, (int(outliers.sum()), 2))
    weights = (rng.random(xy.shape[:2]) >= rng.uniform(*noise.drop_prob)).astype(np.float64)
    weights *= rng.uniform(0.5, 1.0, weights.shape)  # detector confidences
    out = triangulate_linear(rt, xy, weights).reshape(t, 17, 3)
    # whole-body gaps: nobody tracked for 1-8 frames
    n_gaps = rng.poisson(noise.gap_prob_per_s * t / fps)
    for _ in range(n_gaps):
        s = int(rng.integers(0, t))
        out[s : s + int(rng.integers(1, 9))] = np.nan
    # body parts lost for a while (a hand behind the back, the face turned away from every camera)
    for _ in range(rng.poisson(noise.group_drop_per_s * t / fps)):
        group = _GROUPS[int(rng.integers(len(_GROUPS)))]
        s = int(rng.integers(0, t))
        out[s : s + int(rng.uniform(0.5, 6.0) * fps), group] = np.nan
    if rng.random() < noise.face_missing_prob:
        out[:, _GROUPS[0]] = np.nan
    return out


# ---------------------------------------------------------------- data generation


def generate(config: DataConfig, progress: Callable[[str], None] | None = None) -> Dataset:
    """Simulate ``config.sequences`` random routines and capture them with noise."""
    rng = np.random.default_rng(config.seed)
    joints, labels, lengths = [], [], []
    t0 = time.monotonic()
    for i in range(config.sequences):
        body = sample_body(rng)
        r = config.start_radius_m * np.sqrt(rng.random())
        a = rng.uniform(0, 2 * np.pi)
        script = random_script(rng, config.duration_s, start_xy_m=(r * np.cos(a), r * np.sin(a)))
        motion = simulate_user(script, body, config.fps, seed=int(rng.integers(2**31)))
        joints.append(capture(motion.joints_m, rng, config.noise, config.fps).astype(np.float32))
        labels.append(np.array([LABEL_INDEX[str(x)] for x in motion.labels], dtype=np.int64))
        lengths.append(len(labels[-1]))
        if progress is not None and ((i + 1) % 20 == 0 or i + 1 == config.sequences):
            progress(f"simulated {i + 1}/{config.sequences} routines ({time.monotonic() - t0:.0f} s)")
    return Dataset(
        np.concatenate(joints),
        np.concatenate(labels),
        np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        config.fps,
    )


def load_or_generate(
    config: DataConfig, cache_dir: Path, progress: Callable[[str], None] | None = None
) -> Dataset:
    """The dataset from ``cache_dir/action-data-<key>.npz``, generated once."""
    path = Path(cache_dir) / f"action-data-{config.cache_key()}.npz"
    if path.is_file():
        with np.load(path) as z:
            return Dataset(z["joints"], z["labels"], z["starts"], float(z["fps"]))
    data = generate(config, progress)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, joints=data.joints, labels=data.labels, starts=data.starts, fps=data.fps)
    return data


def window_ends(data: Dataset, stride: int = 1) -> NDArray[np.int64]:
    """Global indices of every ``stride``-th frame (each is the last frame of one window)."""
    return np.concatenate(
        [np.arange(data.starts[s], data.starts[s + 1], stride) for s in range(data.num_sequences)]
    ).astype(np.int64)


def _window_index(data: Dataset, ends: NDArray[np.int64], window: int) -> NDArray[np.int64]:
    seq = np.searchsorted(data.starts, ends, side="right") - 1
    first = data.starts[seq]
    idx = ends[:, None] - np.arange(window - 1, -1, -1)[None, :]
    return np.maximum(idx, first[:, None])


def gather_windows(data: Dataset, ends: NDArray[np.int64], window: int) -> NDArray[np.float32]:
    """(B, window, 17, 3) windows ending at ``ends``; frames before a sequence's start repeat its first."""
    return data.joints[_window_index(data, ends, window)]


def transition_weights(data: Dataset, window_s: float, weight: float) -> NDArray[np.float32]:
    """(N,) loss weights: ``weight`` for frames less than ``window_s`` after a label change, else 1."""
    w = np.ones(len(data.labels), dtype=np.float32)
    n = round(window_s * data.fps)
    change = np.flatnonzero(data.labels[1:] != data.labels[:-1]) + 1
    change = change[~np.isin(change, data.starts)]  # a new sequence is not a transition
    for i in change:
        w[i : i + n] = weight
    return w


_FEET = [J["l_ankle"], J["r_ankle"]]
_SWING = [5, 12]  # evidence channels (features.evidence_vector): swing time of each foot
_HEIGHTS = [1, 4, 8, 11]  # foot height and vertical displacement of each foot
_KNEES = [J["l_knee"], J["r_knee"]]


def augmented_index(
    data: Dataset, ends: NDArray[np.int64], window: int, rng: np.random.Generator, config: AugmentConfig
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """(B, window) frame indices of windows ending at ``ends``, each read at a random speed (B, 1)."""
    seq = np.searchsorted(data.starts, ends, side="right") - 1
    first = data.starts[seq]
    speed = rng.uniform(*config.speed, size=(len(ends), 1))
    back = np.rint(np.arange(window - 1, -1, -1)[None, :] * speed).astype(np.int64)
    return np.maximum(ends[:, None] - back, first[:, None]), speed


def augment_windows(
    joints: NDArray[np.floating], rng: np.random.Generator, config: AugmentConfig
) -> tuple[NDArray[np.float32], NDArray[np.float64]]:
    """Windows (B, T, 17, 3) with other leg proportions, step heights (the scale, (B, 1)), lost
    joints and noise."""
    j = np.array(joints, dtype=np.float64)
    b = j.shape[0]
    hips = np.stack([j[:, :, J["l_hip"]], j[:, :, J["r_hip"]]], axis=2)  # (B, T, 2, 3)
    leg = rng.uniform(*config.leg_scale, size=(b, 1, 1, 1))
    for side, (knee, ankle) in enumerate(zip(_KNEES, _FEET, strict=True)):
        hip = hips[:, :, side : side + 1]
        j[:, :, [knee, ankle]] = hip + leg * (j[:, :, [knee, ankle]] - hip)
    # the legs got longer or shorter: the body stands on the same floor
    low = np.nanmin(j[:, :, _FEET, 2], axis=(1, 2))[:, None, None]
    shift = np.nanmin(joints[:, :, _FEET, 2], axis=(1, 2))[:, None, None] - low
    j[..., 2] += np.nan_to_num(shift)
    # a higher or lower step: each foot's and knee's height above its lowest point in the window
    step = rng.uniform(*config.step_scale, size=(b, 1))
    for joint in _FEET + _KNEES:
        z = j[:, :, joint, 2]
        base = np.nanmin(z, axis=1, keepdims=True)
        j[:, :, joint, 2] = base + step * (z - base)
    sigma = rng.uniform(*config.jitter_m, size=(b, 1, 1, 1))
    j += sigma * rng.standard_normal(j.shape)
    for i in np.flatnonzero(rng.random(b) < config.drop_prob):
        n = int(rng.integers(config.drop_joints[0], config.drop_joints[1] + 1))
        j[i, :, rng.choice(NUM_JOINTS, size=n, replace=False)] = np.nan
    return j.astype(np.float32), step


_ARMS = [(J["l_shoulder"], (J["l_elbow"], J["l_wrist"])), (J["r_shoulder"], (J["r_elbow"], J["r_wrist"]))]
_ARM_NOISE_M = 0.006  # the replaced joints' per-frame noise (sigma): about the captures' own


def still_arms(
    joints: NDArray[np.floating], rows: NDArray[np.bool_], rng: np.random.Generator
) -> NDArray[np.float32]:
    """Windows (B, T, 17, 3) whose ``rows`` have arms that hang still: each elbow and wrist keeps its
    window-mean offset from its shoulder (so it follows the trunk's sway, bob and lean) plus capture-like
    noise. Whether a person swings their arms says nothing about whether they step: a network trained
    with and without arm swing in both classes has to find the step in the legs."""
    j = np.array(joints, dtype=np.float32)
    pick = np.flatnonzero(rows)
    if pick.size == 0:
        return j
    sel = j[pick]  # the picked windows, read once (only elbows and wrists are written below)
    for shoulder, hand in _ARMS:
        sh = sel[:, :, shoulder]  # (b, T, 3)
        for joint in hand:
            off = sel[:, :, joint] - sh
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # a joint never known in its window
                mean = np.nanmean(off, axis=1, keepdims=True)
            arm = sh + mean + _ARM_NOISE_M * rng.standard_normal(off.shape).astype(np.float32)
            arm[np.isnan(off)] = np.nan  # a joint unknown in a frame stays unknown
            j[pick, :, joint] = arm
    return j


def batch_inputs(
    data: Dataset,
    ends: NDArray[np.int64],
    window: int,
    features: str = FEATURES_V1,
    rng: np.random.Generator | None = None,
    augment: AugmentConfig | None = None,
    arms_still: float = 0.0,
) -> NDArray[np.float32]:
    """Model inputs of the windows ending at ``ends``; with ``augment`` (and ``rng``) augmented, and
    with ``arms_still`` (and ``rng``) that share of the stepping windows (labelled neither still nor
    ignored) with still arms (:func:`still_arms`): people step without swinging their arms, while
    the arms of the still windows keep their gestures (a wave is still, whatever the legs do)."""
    speed = step = None
    if augment is not None and rng is not None:
        idx, speed = augmented_index(data, ends, window, rng, augment)
        joints, step = augment_windows(data.joints[idx], rng, augment)
        if augment.share < 1.0:  # the other windows as recorded
            plain = np.flatnonzero(rng.random(len(ends)) >= augment.share)
            idx[plain] = _window_index(data, ends[plain], window)
            joints[plain] = data.joints[idx[plain]]
            speed[plain], step[plain] = 1.0, 1.0
    else:
        idx = _window_index(data, ends, window)
        joints = data.joints[idx]
    if arms_still > 0.0 and rng is not None:
        stepping = data.labels[ends] > 0
        joints = still_arms(joints, stepping & (rng.random(len(ends)) < arms_still), rng)
    feats = window_features(joints, data.fps)
    if features not in WITH_EVIDENCE:
        return model_input(feats, None, features)
    if data.evidence is None:
        raise ValueError(f"features {features} need the dataset's step evidence (dataset_from_sequences)")
    ev = data.evidence[idx]
    if speed is not None and step is not None:  # the evidence read at the same speed and step height
        ev = ev.copy()
        ev[..., _SWING] = np.minimum(ev[..., _SWING] / speed[..., None], 1.0)
        ev[..., _HEIGHTS] = np.clip(ev[..., _HEIGHTS] * step[..., None], -0.5, 1.0)
    return model_input(feats, ev, features)


def dataset_from_sequences(
    seqs: list[LabelledSequence],
    steps: StepConfig | None = None,
    progress: Callable[[str], None] | None = None,
) -> Dataset:
    """Labelled sequences (one frame rate, already captured) -> a Dataset with step evidence."""
    if not seqs:
        raise ValueError("no sequences")
    fps = seqs[0].fps
    if any(abs(s.fps - fps) > 1e-9 for s in seqs):
        raise ValueError("every sequence must have the same frame rate (corpus.resample them)")
    cfg = replace(steps or StepConfig(), rate_hz=fps)
    evidence = []
    t0 = time.monotonic()
    for i, s in enumerate(seqs):
        tracker = StepTracker(cfg)
        evidence.append(
            np.stack([evidence_vector(tracker.update(f, k / fps)) for k, f in enumerate(s.joints_m)])
        )
        if progress is not None and ((i + 1) % 100 == 0 or i + 1 == len(seqs)):
            progress(f"step evidence {i + 1}/{len(seqs)} sequences ({time.monotonic() - t0:.0f} s)")
    lengths = [len(s) for s in seqs]
    return Dataset(
        np.concatenate([s.joints_m for s in seqs]).astype(np.float32),
        np.concatenate([s.labels for s in seqs]).astype(np.int64),
        np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        float(fps),
        np.concatenate(evidence).astype(np.float32),
        tuple(s.source for s in seqs),
    )


def captured(seqs: list[LabelledSequence], noise: NoiseConfig, seed: int) -> list[LabelledSequence]:
    """Each clean sequence as the CAVE measures it (:func:`capture`), deterministic for the seed."""
    rng = np.random.default_rng(seed)
    out = []
    for s in seqs:
        j = capture(np.nan_to_num(s.joints_m, nan=0.0), rng, noise, s.fps)
        j[np.isnan(s.joints_m).any(axis=-1)] = np.nan  # unknown in the source stays unknown
        out.append(LabelledSequence(j, s.fps, s.labels, s.tags, s.contacts, s.source, s.name))
    return out


def sampling_weights(data: Dataset, power: float = 0.5) -> NDArray[np.float64]:
    """(N,) probability of each frame ending a training window: every source weighs its frame count
    to the ``power`` (0.5: a small source of real clips is not drowned by a large simulated one);
    ``ignore`` frames never."""
    src = data.frame_sources()
    w = np.zeros(len(src))
    for name in np.unique(src):
        sel = (src == name) & (data.labels >= 0)
        if sel.any():
            w[sel] = sel.sum() ** power / sel.sum()
    return w / w.sum()


# ---------------------------------------------------------------- training


def train_model(
    train: Dataset, val: Dataset, config: TrainConfig, progress: Callable[[str], None] | None = None
) -> tuple[object, dict[str, object]]:
    """Train the SlowFast network; returns (model in eval mode, metrics)."""
    import torch
    from torch import nn

    from pipeline.recognition.model import SkeletonSlowFast, SlowFastConfig  # torch: the train extra

    torch.manual_seed(config.seed)
    torch.set_num_threads(config.threads)
    torch.use_deterministic_algorithms(True)
    rng = np.random.default_rng(config.seed)
    in_channels = FEATURE_CHANNELS[config.features]
    model = SkeletonSlowFast(
        SlowFastConfig(
            in_channels=in_channels,
            num_classes=len(ACTIONS),
            window=config.window,
            alpha=config.alpha,
            slow_channels=config.slow_channels,
            fast_pathway=config.fast_pathway,
        )
    )
    ends_all = window_ends(train)
    p_ends = sampling_weights(train, config.source_power)
    known = train.labels[train.labels >= 0]
    freq = np.bincount(known, minlength=len(ACTIONS)) / len(known)
    inv = 1.0 / np.sqrt(np.maximum(freq, 1e-3))
    class_w = torch.tensor(inv / inv.mean(), dtype=torch.float32)
    loss_fn = nn.CrossEntropyLoss(weight=class_w, label_smoothing=config.label_smoothing, reduction="none")
    tw = transition_weights(train, config.transition_window_s, config.transition_weight)
    frame_w = torch.from_numpy(tw)
    opt = torch.optim.AdamW(model.parameters(), lr=config.lr, weight_decay=config.weight_decay)
    steps_per_epoch = config.windows_per_epoch // config.batch_size
    sched = torch.optim.lr_scheduler.OneCycleLR(
        opt, max_lr=config.lr, total_steps=config.epochs * steps_per_epoch, pct_start=0.15
    )
    augment = AugmentConfig(share=config.augment_share) if config.augment else None
    aug_rng = np.random.default_rng(config.seed + 1)
    val_ends = window_ends(val, stride=3)
    val_ends = val_ends[val.labels[val_ends] >= 0]
    x_val = torch.from_numpy(batch_inputs(val, val_ends, config.window, config.features))
    y_val = val.labels[val_ends]
    history: list[dict[str, float]] = []
    t0 = time.monotonic()
    for epoch in range(config.epochs):
        model.train()
        ends = rng.choice(ends_all, size=steps_per_epoch * config.batch_size, replace=False, p=p_ends)
        total = 0.0
        for b in range(steps_per_epoch):
            e = ends[b * config.batch_size : (b + 1) * config.batch_size]
            x = torch.from_numpy(
                batch_inputs(train, e, config.window, config.features, aug_rng, augment, config.arms_still)
            )
            y = torch.from_numpy(train.labels[e])
            opt.zero_grad()
            w = frame_w[torch.from_numpy(e)]
            loss = (loss_fn(model(x), y) * w).sum() / w.sum()
            loss.backward()
            opt.step()
            sched.step()
            total += loss.item()
        model.eval()
        with torch.no_grad():
            pred = model(x_val).argmax(dim=1).numpy()
        acc = float(np.mean(pred == y_val))
        history.append({"epoch": epoch + 1, "loss": total / steps_per_epoch, "val_window_acc": acc})
        if progress is not None:
            progress(
                f"epoch {epoch + 1}/{config.epochs}: loss {total / steps_per_epoch:.4f}, "
                f"validation window accuracy {acc:.4f} ({time.monotonic() - t0:.0f} s)"
            )
    params = sum(p.numel() for p in model.parameters())
    return model, {"history": history, "parameters": params, "train_s": time.monotonic() - t0}


def export_onnx(
    model: object,
    path: Path,
    window: int,
    fps: float,
    extra: dict[str, str] | None = None,
    features: str = FEATURES_V1,
) -> None:
    """Write the model with a softmax output ``probs`` (B, 4), input ``x`` (B, 119, window), metadata."""
    import onnx
    import torch
    from torch import nn

    class WithSoftmax(nn.Module):
        def __init__(self, inner: nn.Module) -> None:
            super().__init__()
            self.inner = inner

        def forward(self, x: torch.Tensor) -> torch.Tensor:
            return torch.softmax(self.inner(x), dim=1)

    if not isinstance(model, nn.Module):
        raise TypeError(f"export_onnx takes the trained torch module, got {type(model).__name__}")
    wrapped = WithSoftmax(model).eval()
    channels = FEATURE_CHANNELS[features]
    dummy = torch.zeros(1, channels, window)
    path.parent.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the TorchScript exporter's constant-folding notes
        torch.onnx.export(
            wrapped,
            (dummy,),
            str(path),
            input_names=["x"],
            output_names=["probs"],
            dynamic_axes={"x": {0: "batch"}, "probs": {0: "batch"}},
            opset_version=17,
            dynamo=False,
        )
    proto = onnx.load(str(path))
    meta = {"window": str(window), "fps": f"{fps:g}", "classes": ",".join(ACTIONS), "features": features}
    meta.update(extra or {})
    for key, value in meta.items():
        entry = proto.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(proto)
    onnx.save(proto, str(path))
