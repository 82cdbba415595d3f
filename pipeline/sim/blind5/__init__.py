"""blind5: animator-style keyframe generator of labelled in-place stepping skeleton sequences.
Held-out evaluation data only: never train on it.

A seventh motion model, written by a helper on 2026-12-05 from a description of the task only,
without reading the product's code, tests, docs or data, and independently of the other motion
models; numpy only. Each behaviour is a few keyed poses (joint rotations, root offset, height and
yaw) at key times, eased spline interpolation, layers (legs and pelvis, upper body, a slow idle
drift), forward kinematics on a joint hierarchy, then a foot lock with two-bone leg IK so a planted
foot never slides. Marching, side steps out and back, step-togethers, aerobics step-touches and
shuffles (stepping); turns in pivot steps, weight shifts, sway, gestures, looks, stretches, bows,
crouches, rising on tiptoes, idle poses and plain standing (still). README.md beside this file
describes the model, the file format, the label convention and the reference set (seed 50505, 12
files of 60 s). Ported unchanged but for absolute imports, ``InputError`` for bad arguments and lint
rewrites that change no value (the port writes the standalone generator's files byte for byte).
"""

import math
import numbers
from pathlib import Path

import numpy as np

from pipeline.errors import InputError
from pipeline.sim.blind5.capture import capture
from pipeline.sim.blind5.script import FPS, generate

__all__ = ["FPS", "generate", "make_record", "validate_args", "write_set"]


def validate_args(count, seed, duration_s):
    if isinstance(count, bool) or not isinstance(count, numbers.Integral) or not 1 <= count <= 1000:
        raise InputError(f"count must be an integer in 1..1000, got {count!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    if (
        isinstance(duration_s, bool)
        or not isinstance(duration_s, numbers.Real)
        or not math.isfinite(duration_s)
        or not 10.0 <= duration_s <= 3600.0
    ):
        raise InputError(f"duration_s must be a number in 10..3600 seconds, got {duration_s!r}")


def n_frames_for(duration_s):
    return round(float(duration_s) * FPS)


def make_record(seed, idx, n_frames):
    g = generate(seed, idx, n_frames)
    return {
        "joints": capture(g["joints"], seed, idx),
        "fps": np.float64(FPS),
        "labels": g["labels"].astype("<U7"),
        "tags": g["tags"].astype("<U20"),
        "contacts": g["contacts"].astype(bool),
        "source": np.array("blind5"),
    }


def write_set(folder: Path, count: int = 12, seed: int = 50505, duration_s: float = 60.0) -> list[Path]:
    validate_args(count, seed, duration_s)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    n = n_frames_for(duration_s)
    paths = []
    for i in range(count):
        p = folder / f"blind5_{seed}_{i:02d}.npz"
        np.savez(p, **make_record(seed, i, n))
        paths.append(p)
    return paths
