"""blind7: synthetic in-place stepping generator (LIPM / DCM centre-of-mass model). Held-out
evaluation data only: never train on it.

A ninth motion model, written by a helper on 2026-12-06 from a description of the task only, without
reading the product's code, tests, docs or data, and independently of the other motion models; numpy
and scipy only. A footstep and weight plan (``behaviours.py``, ``timeline.py``) sets where and when
each foot lands and how the weight moves between the feet; the centre of mass is a linear inverted
pendulum driven by a divergent-component-of-motion (capture-point) plan integrated backwards from
rest through the planned centre of pressure; swing feet follow minimum-jerk paths, knees come from
two-link leg IK, and the trunk, pelvic drop and arms are damped second-order responses plus posture
and gesture targets (``body.py``). Marching (knee lift or heel kick), side steps out and back,
step-togethers and shuffles (stepping); plain standing, weight shifts, pointing, waving, looks,
turns in pivot steps, stretches, bows, leans, squats, kneeling on one knee, tiptoes, small jumps and
sway (still). A file depends only on (seed, idx, n_frames). README.md beside this file describes
the model, the file format, the label convention and the reference set (seed 70707, 12 files of
60 s). Ported unchanged but for absolute imports, ``InputError`` for bad arguments, the command
line's errors and lint rewrites that change no value (the port writes the standalone generator's
files byte for byte).
"""

import math
import numbers
from pathlib import Path

import numpy as np

from pipeline.errors import InputError
from pipeline.sim.blind7.behaviours import make_person, plan_file
from pipeline.sim.blind7.body import build
from pipeline.sim.blind7.timeline import FPS

__all__ = ["JOINT_NAMES", "LABELS", "TAGS", "make_record", "validate_args", "write_set"]

LABELS = ("still", "forward", "left", "right")
TAGS = (
    "",
    "march",
    "heel_kick",
    "out_back",
    "step_together",
    "shuffle",
    "pause",
    "weight_shift",
    "point",
    "wave",
    "look_around",
    "turn",
    "stretch",
    "bow",
    "lean",
    "squat",
    "kneel",
    "tiptoe",
    "jump",
    "sway",
)
JOINT_NAMES = (
    "nose",
    "left_eye",
    "right_eye",
    "left_ear",
    "right_ear",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hip",
    "right_hip",
    "left_knee",
    "right_knee",
    "left_ankle",
    "right_ankle",
)
NOISE_SD = 0.012
DROP_SHARE = 0.02


def validate_args(count, seed, duration_s):
    if isinstance(count, bool) or not isinstance(count, numbers.Integral) or not 1 <= count <= 1000:
        raise InputError(f"count must be an integer in 1..1000, got {count!r}")
    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    if isinstance(duration_s, bool) or not isinstance(duration_s, numbers.Real):
        raise InputError(f"duration_s must be a number of seconds, got {duration_s!r}")
    if not math.isfinite(float(duration_s)) or not 10.0 <= float(duration_s) <= 3600.0:
        raise InputError(f"duration_s must be finite and within 10..3600 s, got {duration_s!r}")


def _pause_tags(labels, tags, con):
    """Tag in-bout double-support runs of >= 0.2 s as 'pause'."""
    T = len(labels)
    ds = con[:, 0] & con[:, 1] & (labels > 0)
    f = 0
    while f < T:
        if ds[f]:
            g = f
            while g < T and ds[g] and labels[g] == labels[f]:
                g += 1
            if g - f >= round(0.2 * FPS):
                tags[f:g] = "pause"
            f = g
        else:
            f += 1


def _dropout(rng, T, J=17):
    target = round(DROP_SHARE * T * J)
    mask = np.zeros((T, J), bool)
    n = 0
    while n < target:
        j = int(rng.integers(J))
        ln = int(rng.integers(1, 13))
        a = int(rng.integers(0, max(1, T - ln + 1)))
        seg = mask[a : a + ln, j]
        add = int((~seg).sum())
        if n + add > target + 6:
            continue
        seg[:] = True
        n += add
    return mask


def make_record(seed, idx, n_frames, clean=False):
    """One record as a dict of the file's arrays (plus 'joints_clean' etc. if clean)."""
    n_frames = int(n_frames)
    P = make_person(np.random.default_rng([seed, idx, 0]))
    tl = plan_file(P, np.random.default_rng([seed, idx, 1]), n_frames)
    Jc, extra = build(tl)
    T = n_frames
    labels_i = tl.label[:T].astype(int)
    tags = tl.tag[:T].copy()
    con = tl.con[:T].copy()
    _pause_tags(labels_i, tags, con)
    noise = np.random.default_rng([seed, idx, 2]).normal(0.0, NOISE_SD, Jc.shape)
    J = (Jc + noise).astype(np.float32)
    J[_dropout(np.random.default_rng([seed, idx, 3]), T)] = np.nan
    rec = {
        "joints": J,
        "fps": np.float64(FPS),
        "labels": np.array(LABELS, dtype="<U7")[labels_i],
        "tags": tags.astype("<U20"),
        "contacts": con,
        "source": np.array("blind7"),
    }
    if clean:
        rec["joints_clean"] = Jc
        rec["person"] = P
        rec["bouts"] = list(tl.bouts)
        rec.update(extra)
    return rec


def file_name(seed, idx):
    return f"blind7_{seed}_{idx:02d}.npz"


def write_set(folder, count=12, seed=70707, duration_s=60.0):
    validate_args(count, seed, duration_s)
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    n_frames = round(float(duration_s) * FPS)
    out = []
    for idx in range(int(count)):
        rec = make_record(int(seed), idx, n_frames)
        path = folder / file_name(int(seed), idx)
        with open(path, "wb") as fh:
            np.savez(fh, **rec)
        out.append(path)
    return out
