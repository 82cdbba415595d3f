"""blind6: a central-pattern-generator stepping-in-place generator. Held-out evaluation data only:
never train on it.

An eighth motion model, written by a helper on 2026-12-06 from a description of the task only,
without reading the product's code, tests, docs or data, and independently of the other motion
models; numpy and scipy only. Four coupled Hopf oscillators (the legs in anti-phase, each arm
locked to the other side's leg) set the rhythm; a leg swings while its phase is in its swing
window, a step planner chooses what it steps (marching, side steps out and back, step-togethers,
shuffles, step-touches), the oscillators' amplitude ramps up and down at a bout's ends and a
frozen phase makes a pause; joint angles, forward kinematics, two-link leg IK and a pinned stance
foot make the skeleton. Still behaviours: plain standing, idle poses, sway, dance on the spot,
weight shifts, looks, gestures, stretches, bows, leans, crouches and standing up, squats, picking
something up, tiptoes, small jumps, kneeling on one knee and turns in pivot steps. README.md
beside this file describes the model, the file format, the label convention and the reference
set (seed 60606, 12 files of 60 s). Ported unchanged but for absolute imports, ``InputError``
for bad arguments, the command line's errors and lint rewrites that change no value (the port
writes the standalone generator's files byte for byte).
"""

import math
from pathlib import Path

import numpy as np

from pipeline.errors import InputError
from pipeline.sim.blind6.script import make_record

__all__ = ["make_record", "validate_args", "write_set"]


def validate_args(count, seed, duration_s):
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or not 1 <= count <= 1000:
        raise InputError(f"count must be an integer in 1..1000, got {count!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    if (
        isinstance(duration_s, bool)
        or not isinstance(duration_s, (int, float, np.integer, np.floating))
        or not math.isfinite(duration_s)
        or not 10 <= duration_s <= 3600
    ):
        raise InputError(f"duration must be a finite number in 10..3600 s, got {duration_s!r}")


def write_set(folder, count=12, seed=60606, duration_s=60.0):
    validate_args(count, seed, duration_s)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    n = round(30 * float(duration_s))
    paths = []
    for idx in range(int(count)):
        rec = make_record(int(seed), idx, n)
        p = folder / f"blind6_{int(seed)}_{idx:02d}.npz"
        np.savez(p, **rec)
        paths.append(p)
    return paths
