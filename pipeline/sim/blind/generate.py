"""Sequences and sets from the blind generator: configs, sensor noise and the NPZ writer.

A set spreads its people over the ranges that matter for evaluation: heights 1.48–1.98 m, marching
cadence 0.6–2.4 steps/s (log-spaced) and foot lift 3–25 cm are stratified (one draw per stratum,
shuffled), everything else about a person is drawn independently (body.sample_style).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.blind.activities import ACTIVITIES, build_script
from pipeline.sim.blind.body import HEIGHT_RANGE_M, STYLE_BOUNDS, Body, Style, sample_body, sample_style
from pipeline.sim.blind.kinematics import Kinematics, compose
from pipeline.sim.blind.script import Script, frame_labels
from pipeline.skeleton import SkeletonSequence, save_npz

SOURCE = "blind"  # the NPZ's source field starts with this
DEFAULT_SEED = 4242


@dataclass(frozen=True, slots=True)
class NoiseConfig:
    """Sensor imperfection: Gaussian noise of noise_m (sd, metres, per coordinate) on every joint,
    and a fraction ``dropout`` of joint-frames set to NaN (in runs of ~3 frames, as occlusions are)."""

    noise_m: float = 0.012
    dropout: float = 0.02

    def __post_init__(self) -> None:
        if not (math.isfinite(self.noise_m) and 0.0 <= self.noise_m <= 0.2):
            raise InputError(f"noise_m must be between 0 and 0.2 m, got {self.noise_m}")
        if not (math.isfinite(self.dropout) and 0.0 <= self.dropout <= 0.5):
            raise InputError(f"dropout must be a fraction between 0 and 0.5, got {self.dropout}")


@dataclass(frozen=True, slots=True)
class SequenceConfig:
    """One person's sequence.

    duration_s / fps: its length. yaw_deg: the facing at the start (0 = +Y, counter-clockwise);
    centre_xy: the point between the feet at the start (metres, CAVE frame, within 1 m of the
    centre). activities: a fixed programme (names from script.ACTIVITIES) instead of a random one.
    """

    duration_s: float = 60.0
    fps: float = 30.0
    yaw_deg: float = 0.0
    centre_xy: tuple[float, float] = (0.0, 0.0)
    activities: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if not (math.isfinite(self.duration_s) and 5.0 <= self.duration_s <= 3600.0):
            raise InputError(f"duration_s must be between 5 and 3600 s, got {self.duration_s}")
        if not (math.isfinite(self.fps) and 10.0 <= self.fps <= 240.0):
            raise InputError(f"fps must be between 10 and 240, got {self.fps}")
        if not (math.isfinite(self.yaw_deg) and -180.0 <= self.yaw_deg <= 180.0):
            raise InputError(f"yaw_deg must be between -180 and 180, got {self.yaw_deg}")
        if len(self.centre_xy) != 2 or not math.hypot(*self.centre_xy) <= 1.0:
            raise InputError(
                f"centre_xy must be an (x, y) pair within 1 m of the centre, got {self.centre_xy}"
            )
        if self.activities is not None:
            unknown = [a for a in self.activities if a not in ACTIVITIES]
            if unknown or not self.activities:
                raise InputError(
                    f"activities must be a non-empty list from {list(ACTIVITIES)}, got {unknown or []}"
                )


@dataclass(frozen=True, slots=True)
class Generated:
    """A generated sequence with its ground truth.

    sequence: what is written (noisy joints, labels, tags, contacts). clean: the kinematics before
    noise (joints, contacts, facing yaw per frame, pelvis).
    """

    sequence: SkeletonSequence
    clean: Kinematics
    body: Body
    style: Style
    config: SequenceConfig
    script: Script


def add_noise(
    joints_m: NDArray[np.float64], noise: NoiseConfig, rng: np.random.Generator
) -> NDArray[np.float64]:
    """A noisy copy of (T, 17, 3) joints: Gaussian jitter, and runs of NaN joints."""
    out = joints_m + rng.normal(0.0, noise.noise_m, joints_m.shape) if noise.noise_m > 0 else joints_m.copy()
    n, j = joints_m.shape[:2]
    target = int(np.rint(noise.dropout * n * j))
    dropped = np.zeros((n, j), dtype=bool)
    while dropped.sum() < target:
        start, joint = int(rng.integers(n)), int(rng.integers(j))
        length = min(int(rng.geometric(1 / 3)), target - int(dropped.sum()))
        stop = min(n, start + length)
        if dropped[start:stop, joint].any():
            continue
        dropped[start:stop, joint] = True
    out[dropped] = np.nan
    return np.asarray(out, dtype=np.float64)


def generate_sequence(
    config: SequenceConfig,
    body: Body,
    style: Style,
    noise: NoiseConfig,
    rng: np.random.Generator,
    source: str = SOURCE,
) -> Generated:
    """Script, skeleton, labels and noise for one person."""
    n = int(np.rint(config.duration_s * config.fps))
    script = build_script(
        body, style, rng, n, config.fps, config.yaw_deg, config.centre_xy, config.activities
    )
    kin = compose(body, style, script, rng)
    labels, tags = frame_labels(script)
    joints = add_noise(kin.joints_m, noise, rng)
    seq = SkeletonSequence(
        joints_m=joints,
        fps=config.fps,
        labels=tuple(labels),
        tags=tuple(tags),
        contacts=kin.contact,
        source=source,
    )
    return Generated(seq, kin, body, style, config, script)


def _strata(rng: np.random.Generator, count: int) -> NDArray[np.float64]:
    """``count`` values in [0, 1), one per equal stratum, in random order."""
    return np.asarray(
        rng.permutation((np.arange(count) + rng.uniform(0.0, 1.0, count)) / count), dtype=np.float64
    )


def generate_set(
    count: int = 12, duration_s: float = 60.0, seed: int = DEFAULT_SEED, noise: NoiseConfig | None = None
) -> list[Generated]:
    """``count`` people, each with their own body, style, facing and position (reproducible by seed)."""
    if not 1 <= count <= 1000:
        raise InputError(f"count must be between 1 and 1000, got {count}")
    noise = NoiseConfig() if noise is None else noise
    root = np.random.default_rng(seed)
    heights = HEIGHT_RANGE_M[0] + _strata(root, count) * (HEIGHT_RANGE_M[1] - HEIGHT_RANGE_M[0])
    c_lo, c_hi = STYLE_BOUNDS["cadence_hz"]
    cadences = np.exp(np.log(c_lo) + _strata(root, count) * (np.log(c_hi) - np.log(c_lo)))
    l_lo, l_hi = STYLE_BOUNDS["march_lift_m"]
    lifts = l_lo + _strata(root, count) * (l_hi - l_lo)
    out = []
    for i, child in enumerate(np.random.SeedSequence(seed).spawn(count)):
        rng = np.random.default_rng(child)
        body = sample_body(rng, float(heights[i]))
        style = sample_style(rng, cadence_hz=float(cadences[i]), march_lift_m=float(lifts[i]))
        radius, angle = 0.8 * math.sqrt(rng.uniform()), rng.uniform(-math.pi, math.pi)
        config = SequenceConfig(
            duration_s=duration_s,
            yaw_deg=float(rng.uniform(-180.0, 180.0)),
            centre_xy=(radius * math.cos(angle), radius * math.sin(angle)),
        )
        out.append(
            generate_sequence(config, body, style, noise, rng, source=f"{SOURCE} seed={seed} person={i}")
        )
    return out


def write_set(
    folder: str | Path,
    count: int = 12,
    duration_s: float = 60.0,
    seed: int = DEFAULT_SEED,
    noise_m: float = 0.012,
    dropout: float = 0.02,
) -> list[Path]:
    """Write ``count`` SPEC skeleton NPZ files (``blind_<seed>_<i>.npz``) into ``folder``; their paths."""
    noise = NoiseConfig(noise_m=noise_m, dropout=dropout)
    return save_set(folder, generate_set(count=count, duration_s=duration_s, seed=seed, noise=noise), seed)


def save_set(folder: str | Path, sequences: list[Generated], seed: int) -> list[Path]:
    """Write generated sequences as ``blind_<seed>_<i>.npz`` into ``folder`` (created if needed)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i, g in enumerate(sequences):
        path = folder / f"blind_{seed}_{i:02d}.npz"
        save_npz(path, g.sequence)
        paths.append(path)
    return paths
