"""Capture model: per-coordinate Gaussian noise and short joint drop-out runs."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

NOISE_SD = 0.012  # metres, per coordinate
DROP_FRACTION = 0.02  # fraction of joint values set to NaN
MAX_RUN = 12  # longest drop-out run in frames

# relative drop-out propensity per COCO joint: extremities most, torso least
DROP_WEIGHTS = np.array(
    [
        0.8,
        0.8,
        0.8,
        0.9,
        0.9,  # face
        0.5,
        0.5,  # shoulders
        1.2,
        1.2,  # elbows
        2.6,
        2.6,  # wrists
        0.5,
        0.5,  # hips
        1.2,
        1.2,  # knees
        2.6,
        2.6,  # ankles
    ]
)


def dropout_mask(rng: np.random.Generator, n_frames: int, n_joints: int = 17) -> NDArray[np.bool_]:
    """Boolean (T, J) mask of dropped joints made of separate runs of 1-12 frames.

    Runs of one joint never touch each other, so every maximal run is 1-12 frames long.
    """
    mask = np.zeros((n_frames, n_joints), dtype=bool)
    target = round(DROP_FRACTION * n_frames * n_joints)
    p = DROP_WEIGHTS[:n_joints] / DROP_WEIGHTS[:n_joints].sum()
    count, tries = 0, 0
    while count < target and tries < 100_000:
        tries += 1
        j = int(rng.choice(n_joints, p=p))
        length = int(rng.integers(1, MAX_RUN + 1))
        length = min(length, target - count) if target - count < length else length
        s = int(rng.integers(0, max(n_frames - length, 1)))
        e = min(s + length, n_frames)
        if mask[max(s - 1, 0) : min(e + 1, n_frames), j].any():
            continue
        mask[s:e, j] = True
        count += e - s
    return mask


def apply_capture(
    clean: NDArray[np.float64], noise_rng: np.random.Generator, drop_rng: np.random.Generator
) -> NDArray[np.float32]:
    """Noisy float32 joints with NaN drop-outs."""
    noisy = clean + noise_rng.normal(0.0, NOISE_SD, size=clean.shape)
    noisy[dropout_mask(drop_rng, clean.shape[0], clean.shape[1])] = np.nan
    return noisy.astype(np.float32)
