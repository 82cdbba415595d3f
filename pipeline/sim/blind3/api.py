"""Public entry points: clean sequence generation, the camera-like observation model and the files.

Sequence ``idx`` of seed ``seed`` depends on (seed, idx) only: the motion uses the random stream
``[seed, idx, 0]``, the noise and drop-outs ``[seed, idx, 1]``. ``write_set`` writes a set as
``blind3_<seed>_<idx>.npz`` files.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.blind3.events import Generator
from pipeline.sim.blind3.model import FloatArray

SOURCE = "blind3"  # the NPZ's source field
DEFAULT_SEED = 31337
DEFAULT_COUNT = 12
DEFAULT_DURATION_S = 60.0
FPS = 30.0
MIN_DURATION_S = 1.0  # much shorter sequences can fail (no room for drop-out runs of up to 12 frames)
MAX_DURATION_S = 3600.0
MAX_COUNT = 1000
FILE_KEYS = ("joints", "fps", "labels", "tags", "contacts", "source")

JOINTS = [
    "nose",
    "l_eye",
    "r_eye",
    "l_ear",
    "r_ear",
    "l_shoulder",
    "r_shoulder",
    "l_elbow",
    "r_elbow",
    "l_wrist",
    "r_wrist",
    "l_hip",
    "r_hip",
    "l_knee",
    "r_knee",
    "l_ankle",
    "r_ankle",
]
# relative chance of losing a joint (wrists/ankles/ears more often than the torso)
DROP_WEIGHT = np.array([0.7, 0.8, 0.8, 1.2, 1.2, 0.6, 0.6, 1.3, 1.3, 2.0, 2.0, 0.8, 0.8, 1.0, 1.0, 1.5, 1.5])
NOISE_SD = 0.012
DROP_RATE = 0.02


def generate_clean(
    seed: int, idx: int, duration: float = 60.0, fps: float = 30.0
) -> tuple[Generator, FloatArray]:
    """The planned and simulated sequence and its noise-free joints (T, 17, 3) in m."""
    g = Generator(seed, idx, duration, fps)
    g.run()
    J = g.assemble()
    return g, J


def observe(
    J: FloatArray, seed: int, idx: int, noise_sd: float = NOISE_SD, drop_rate: float = DROP_RATE
) -> tuple[NDArray[np.float32], NDArray[np.bool_]]:
    """Noisy float32 joints with drop-outs set to NaN, and the (T, 17) drop-out mask."""
    rng = np.random.default_rng([seed, idx, 1])
    Y = J + rng.normal(0.0, noise_sd, J.shape)
    T, K = J.shape[:2]
    p = DROP_WEIGHT / DROP_WEIGHT.sum()
    target = round(drop_rate * T * K)
    mask = np.zeros((T, K), bool)
    n = 0
    while n < target:
        k = rng.choice(K, p=p)
        L = int(min(12, rng.geometric(0.3)))  # short runs: mean ~3 frames, at most 12
        a = int(rng.integers(0, T - L + 1))
        if mask[max(a - 1, 0) : a + L + 1, k].any():
            continue  # keep runs separate (no merging into long gaps)
        mask[a : a + L, k] = True
        n += L
    Y[mask] = np.nan
    return Y.astype(np.float32), mask


def make_record(
    seed: int, idx: int, duration: float = 60.0, fps: float = 30.0
) -> tuple[dict[str, NDArray[Any]], Generator, FloatArray, NDArray[np.bool_]]:
    """The arrays of file idx (FILE_KEYS), the generator, the clean joints and the drop-out mask."""
    g, J = generate_clean(seed, idx, duration, fps)
    Y, mask = observe(J, seed, idx)
    return record(g, Y, fps), g, J, mask


def record(g: Generator, joints: NDArray[np.floating], fps: float = FPS) -> dict[str, NDArray[Any]]:
    """The arrays of a file (FILE_KEYS) of the simulated sequence ``g`` with ``joints``."""
    return dict(
        joints=np.asarray(joints, dtype=np.float32),
        fps=np.float64(fps),
        labels=np.asarray(g.labels, dtype="<U7"),
        tags=np.asarray(g.tags, dtype="<U20"),
        contacts=(g.gstate == 0).astype(bool),
        source=np.array(SOURCE),
    )


def file_name(seed: int, idx: int) -> str:
    """The name of file idx of a set: ``blind3_<seed>_<idx:02d>.npz``."""
    return f"blind3_{seed}_{idx:02d}.npz"


def check_set_args(folder: str | Path, count: int, seed: int, duration_s: float) -> Path:
    """``folder`` as a Path, or InputError naming the first bad argument (nothing is created)."""
    if isinstance(count, bool) or not isinstance(count, int) or not 1 <= count <= MAX_COUNT:
        raise InputError(f"count must be a whole number between 1 and {MAX_COUNT}, got {count}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"seed must be a whole number >= 0, got {seed}")
    if (
        isinstance(duration_s, bool)
        or not isinstance(duration_s, int | float)
        or not (math.isfinite(duration_s) and MIN_DURATION_S <= duration_s <= MAX_DURATION_S)
    ):
        raise InputError(
            f"duration must be between {MIN_DURATION_S:g} and {MAX_DURATION_S:g} s, got {duration_s}"
        )
    p = Path(folder)
    if p.exists() and not p.is_dir():
        raise InputError(f"{p} exists and is not a folder")
    return p


def write_set(
    folder: Path,
    count: int = DEFAULT_COUNT,
    seed: int = DEFAULT_SEED,
    duration_s: float = DEFAULT_DURATION_S,
) -> list[Path]:
    """Write sequences 0..count-1 of ``seed`` as ``blind3_<seed>_<idx:02d>.npz`` into ``folder``
    (created if needed) at 30 fps; their paths. Bad arguments raise InputError before anything
    is written."""
    out = check_set_args(folder, count, seed, duration_s)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(count):
        rec = make_record(seed, i, duration_s, FPS)[0]
        path = out / file_name(seed, i)
        np.savez(path, **rec)  # type: ignore[arg-type]  # numpy stubs take allow_pickle as a keyword too
        paths.append(path)
    return paths
