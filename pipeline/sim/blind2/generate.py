"""blind2 sequences and sets: capture noise, the generated record and the NPZ writer.

Sequence i of a set uses ``SeedSequence([seed, i])``: its first child drives the motion, its second
the capture noise (Gaussian, sd 1.2 cm on every coordinate; then 2 % of (frame, joint) pairs set to
NaN in all three coordinates). The bout kinds are balanced across a set's files by counts that the
sequences share, so a set is generated in order: sequence i alone is not file i of a set.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.blind2.body import Body
from pipeline.sim.blind2.feet import render_feet
from pipeline.sim.blind2.motion import Motion, compose
from pipeline.sim.blind2.profiles import FPS
from pipeline.sim.blind2.script import Planner, StepCounts
from pipeline.sim.blind2.truth import Behaviour, Bout, Turn

SOURCE = "blind2-heldout"  # the NPZ's source field
DEFAULT_SEED = 2026
DEFAULT_COUNT = 12
DEFAULT_DURATION_S = 60.0
NOISE_SD_M = 0.012  # capture noise per coordinate
NAN_RATE = 0.02  # share of (frame, joint) pairs set to NaN
FILE_KEYS = ("joints", "fps", "labels", "tags", "contacts", "source")  # an NPZ's arrays, in order


@dataclass(frozen=True, slots=True)
class SetConfig:
    """A set: ``count`` sequences of ``duration_s`` seconds each (at 30 fps) from ``seed``."""

    count: int = DEFAULT_COUNT
    seed: int = DEFAULT_SEED
    duration_s: float = DEFAULT_DURATION_S

    def __post_init__(self) -> None:
        if isinstance(self.count, bool) or not isinstance(self.count, int) or not 1 <= self.count <= 1000:
            raise InputError(f"count must be a whole number between 1 and 1000, got {self.count}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise InputError(f"seed must be a whole number >= 0, got {self.seed}")
        if not (math.isfinite(self.duration_s) and 5.0 <= self.duration_s <= 3600.0):
            raise InputError(f"duration_s must be between 5 and 3600 s, got {self.duration_s}")

    @property
    def n_frames(self) -> int:
        return round(float(self.duration_s * FPS))


@dataclass(frozen=True, slots=True, eq=False)
class Generated:
    """One generated sequence: what its file holds, and the ground truth behind it.

    joints_m: (T, 17, 3) float32 noisy joints (NaN where dropped); labels: (T,) ``<U7``; tags:
    (T,) ``<U18``; contacts: (T, 2) bool. clean: the motion before noise; bouts, turns and
    behaviours: what the script planned.
    """

    index: int
    joints_m: NDArray[np.float32]
    labels: NDArray[np.str_]
    tags: NDArray[np.str_]
    contacts: NDArray[np.bool_]
    clean: Motion
    body: Body
    bouts: tuple[Bout, ...]
    turns: tuple[Turn, ...]
    behaviours: tuple[Behaviour, ...]

    def __post_init__(self) -> None:
        n = self.joints_m.shape[0]
        if self.labels.shape != (n,) or self.tags.shape != (n,) or self.contacts.shape != (n, 2):
            raise ValueError(
                f"labels, tags (T,) and contacts (T, 2) must match the {n} frames of the joints, got "
                f"{self.labels.shape}, {self.tags.shape}, {self.contacts.shape}"
            )

    def arrays(self) -> dict[str, NDArray]:
        """The arrays of its NPZ file, by FILE_KEYS."""
        return {
            "joints": self.joints_m,
            "fps": np.array(FPS, dtype=np.float64),
            "labels": self.labels,
            "tags": self.tags,
            "contacts": self.contacts,
            "source": np.array(SOURCE),
        }


def add_capture_noise(clean_m: NDArray[np.float64], rng: np.random.Generator) -> NDArray[np.float32]:
    """(T, 17, 3) float32: Gaussian noise of sd NOISE_SD_M, then NAN_RATE of the (frame, joint)
    pairs NaN in all three coordinates."""
    noisy = clean_m + rng.normal(0, NOISE_SD_M, clean_m.shape)
    nanmask = rng.random(clean_m.shape[:2]) < NAN_RATE
    noisy[nanmask] = np.nan
    return noisy.astype(np.float32)


def generate_sequence(seed: int, index: int, counts: StepCounts, n_frames: int) -> Generated:
    """Sequence ``index`` of the set from ``seed``; ``counts`` carries over from the sequences before it."""
    motion_seed, noise_seed = np.random.SeedSequence([seed, index]).spawn(2)
    planner = Planner(np.random.default_rng(motion_seed), n_frames, counts)
    planner.plan()
    b = planner.body
    feet = render_feet(planner.feet, n_frames, b.ankle_height_m, b.thigh_m, b.shank_m)
    clean = compose(b, feet, planner.channels, planner.balance, planner.rng)
    joints = add_capture_noise(clean.joints_m, np.random.default_rng(noise_seed))
    return Generated(
        index=index,
        joints_m=joints,
        labels=planner.labels.copy(),
        tags=planner.tags.copy(),
        contacts=clean.contacts.astype(bool),
        clean=clean,
        body=b,
        bouts=tuple(planner.bouts),
        turns=tuple(planner.turns),
        behaviours=tuple(planner.behaviours),
    )


def generate_set(config: SetConfig | None = None) -> list[Generated]:
    """The sequences of a set, generated in order."""
    config = SetConfig() if config is None else config
    counts = StepCounts()
    return [generate_sequence(config.seed, i, counts, config.n_frames) for i in range(config.count)]


def file_name(seed: int, index: int) -> str:
    return f"blind2_{seed}_{index:02d}.npz"


def check_folder(folder: str | Path) -> Path:
    """``folder`` as a Path, or InputError if it exists and is not a folder (nothing is created)."""
    p = Path(folder)
    if p.exists() and not p.is_dir():
        raise InputError(f"{p} exists and is not a folder")
    return p


def save_set(folder: str | Path, sequences: list[Generated], seed: int) -> list[Path]:
    """Write sequences as ``blind2_<seed>_<i>.npz`` into ``folder`` (created if needed); their paths."""
    p = check_folder(folder)
    p.mkdir(parents=True, exist_ok=True)
    paths = []
    for g in sequences:
        path = p / file_name(seed, g.index)
        np.savez_compressed(path, **g.arrays())  # type: ignore[arg-type]
        paths.append(path)
    return paths


def write_set(folder: str | Path, config: SetConfig | None = None) -> list[Path]:
    """Generate a set and write it into ``folder``; the paths of its files."""
    config = SetConfig() if config is None else config
    check_folder(folder)
    return save_set(folder, generate_set(config), config.seed)
