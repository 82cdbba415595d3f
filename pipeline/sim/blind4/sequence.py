"""Assemble one sequence and write sets of NPZ files.

Sequence ``idx`` of seed ``seed`` depends on (seed, idx) and the duration only: every stage draws
from its own stream ``numpy.random.default_rng([seed, idx, stream])`` (body, plan, pelvis,
events, noise, drop-outs, arms). ``write_set`` writes a set as ``blind4_<seed>_<idx:02d>.npz``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.blind4.body import Body, sample_body
from pipeline.sim.blind4.capture import apply_capture
from pipeline.sim.blind4.com import PelvisTrack, pelvis_motion
from pipeline.sim.blind4.feet import FootTracks, foot_tracks
from pipeline.sim.blind4.legs import two_link_ik
from pipeline.sim.blind4.mathutil import FPS
from pipeline.sim.blind4.plan import Plan, make_plan
from pipeline.sim.blind4.upper import render_events, upper_body

SOURCE = "blind4"  # the NPZ's source field
DEFAULT_SEED = 60606  # the reference held-out set: seed 60606, 12 sequences of 60 s
DEFAULT_COUNT = 12
DEFAULT_DURATION_S = 60.0
MIN_DURATION_S = 10.0  # the planner needs room for still stretches around a bout
MAX_DURATION_S = 3600.0
MAX_COUNT = 1000
FILE_KEYS = ("joints", "fps", "labels", "tags", "contacts", "source")
# random streams derived from (seed, index, stream)
STREAM_BODY, STREAM_PLAN, STREAM_MOTION, STREAM_UPPER, STREAM_NOISE, STREAM_DROP, STREAM_ARMS = range(1, 8)


@dataclass
class CleanSequence:
    """Noise-free skeleton with its plan and intermediate tracks."""

    joints: NDArray[np.float64]  # (T, 17, 3)
    body: Body
    plan: Plan
    feet: FootTracks
    pelvis: PelvisTrack
    ik_clamped: int

    @property
    def contacts(self) -> NDArray[np.bool_]:
        """Ground-truth foot contacts (T, 2)."""
        return self.feet.contact


def n_frames_for(duration_s: float) -> int:
    """Number of frames for a duration at 30 fps."""
    return round(duration_s * FPS)


def rng_for(seed: int, idx: int, stream: int) -> np.random.Generator:
    """The random stream ``stream`` (STREAM_*) of sequence ``idx`` of ``seed``."""
    return np.random.default_rng([seed, idx, stream])


def generate_clean(seed: int, idx: int, duration_s: float) -> CleanSequence:
    """Noise-free sequence ``idx`` of ``seed``; depends on (seed, idx, duration) only."""
    n = n_frames_for(duration_s)
    body = sample_body(rng_for(seed, idx, STREAM_BODY))
    plan = make_plan(rng_for(seed, idx, STREAM_PLAN), body, n)
    feet = foot_tracks(plan)
    sig = render_events(plan, body, rng_for(seed, idx, STREAM_UPPER))
    pelvis = pelvis_motion(
        plan, feet, body, rng_for(seed, idx, STREAM_MOTION), sig.pelvis_back, sig.pelvis_down
    )
    ankles = feet.ankles(body)
    knees = np.empty((n, 2, 3))
    clamped = 0
    for f in range(2):
        knees[:, f], ankles[:, f], c = two_link_ik(
            pelvis.hips[:, f], ankles[:, f], feet.yaw[:, f], body.thigh, body.shank
        )
        clamped += c
    up = upper_body(plan, body, feet, pelvis, sig, rng_for(seed, idx, STREAM_ARMS))
    joints = np.empty((n, 17, 3))
    joints[:, 0:5] = up.head
    joints[:, 5:7] = up.shoulders
    joints[:, 7:9] = up.elbows
    joints[:, 9:11] = up.wrists
    joints[:, 11:13] = pelvis.hips
    joints[:, 13:15] = knees
    joints[:, 15:17] = ankles
    return CleanSequence(joints=joints, body=body, plan=plan, feet=feet, pelvis=pelvis, ik_clamped=clamped)


def generate(seed: int, idx: int, duration_s: float) -> dict[str, NDArray[Any]]:
    """Arrays of one output file (FILE_KEYS: noisy joints, fps, labels, tags, contacts, source)."""
    clean = generate_clean(seed, idx, duration_s)
    joints = apply_capture(clean.joints, rng_for(seed, idx, STREAM_NOISE), rng_for(seed, idx, STREAM_DROP))
    return {
        "joints": joints,
        "fps": np.asarray(FPS, dtype=np.float64),
        "labels": clean.plan.labels.astype("<U7"),
        "tags": clean.plan.tags.astype("<U20"),
        "contacts": clean.contacts.astype(bool),
        "source": np.array(SOURCE),
    }


def file_name(seed: int, idx: int) -> str:
    """The name of file ``idx`` of a set: ``blind4_<seed>_<idx:02d>.npz``."""
    return f"blind4_{seed}_{idx:02d}.npz"


def _is_whole(x: object) -> bool:
    return isinstance(x, int | np.integer) and not isinstance(x, bool)


def validate_args(folder: str | Path, count: int, seed: int, duration_s: float) -> Path:
    """``folder`` as a Path, or InputError naming the first bad argument (nothing is created)."""
    if not isinstance(folder, str | Path) or str(folder) == "":
        raise InputError(f"the output folder must be a non-empty path, got {folder!r}")
    out = Path(folder)
    if out.exists() and not out.is_dir():
        raise InputError(f"{out} exists and is not a folder")
    parent = next((p for p in out.absolute().parents if p.exists()), None)
    if parent is not None and not parent.is_dir():
        raise InputError(f"{parent} is not a folder, so {out} cannot be made")
    if not _is_whole(count) or not 1 <= int(count) <= MAX_COUNT:
        raise InputError(f"count must be a whole number between 1 and {MAX_COUNT}, got {count!r}")
    if not _is_whole(seed) or int(seed) < 0:
        raise InputError(f"seed must be a whole number >= 0, got {seed!r}")
    if (
        isinstance(duration_s, bool)
        or not isinstance(duration_s, int | float | np.integer | np.floating)
        or not math.isfinite(float(duration_s))
        or not MIN_DURATION_S <= float(duration_s) <= MAX_DURATION_S
    ):
        raise InputError(
            f"duration must be between {MIN_DURATION_S:g} and {MAX_DURATION_S:g} s, got {duration_s!r}"
        )
    return out


def write_set(
    folder: Path,
    count: int = DEFAULT_COUNT,
    seed: int = DEFAULT_SEED,
    duration_s: float = DEFAULT_DURATION_S,
) -> list[Path]:
    """Write sequences 0..count-1 of ``seed``, ``duration_s`` seconds each at 30 fps, as
    ``blind4_<seed>_<idx:02d>.npz`` into ``folder`` (created if needed); their paths. Bad arguments
    raise InputError before anything is written."""
    out = validate_args(folder, count, seed, duration_s)
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    for idx in range(int(count)):
        path = out / file_name(int(seed), idx)
        np.savez(path, **generate(int(seed), idx, float(duration_s)))  # type: ignore[arg-type]
        paths.append(path)
    return paths
