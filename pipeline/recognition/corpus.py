"""The labelled corpus the action model is trained and evaluated on: sequences from every source.

Sources (each a list of :class:`~pipeline.recognition.dataset.LabelledSequence`, clean, any fps):

- ``sim``: our own simulator's random routines (``pipeline.sim``);
- ``gait``: the second motion model's routines (:func:`gait_model`); ``blind``, ``blind2`` and
  ``blind3``: the third, fourth and fifth (:func:`independent_model`, other seeds than their held-out
  sets; the sixth to ninth, ``pipeline.sim.blind4`` to ``blind7``, are never trained on);
- any folder of labelled SPEC NPZ files (the still-behaviour library, the second motion model,
  converted real motion capture, recorded takes): :func:`from_folder`, the source named by the
  files' ``source`` or by the folder.

Nothing here looks inside a generator: sequences are data. :func:`resample` brings a sequence to
the model's frame rate, :func:`mirrored` swaps left and right (labels included) and
:func:`warped` plays it faster or slower, for augmentation.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterable
from dataclasses import replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.recognition.dataset import IGNORE_INDEX, LabelledSequence, encode_labels, load_labelled
from pipeline.skeleton import ACTIONS, FLIP_PAIRS, NUM_JOINTS, SkeletonSequence

log = logging.getLogger(__name__)

_LEFT, _RIGHT = ACTIONS.index("left"), ACTIONS.index("right")


def resample(seq: LabelledSequence, fps: float, speed: float = 1.0) -> LabelledSequence:
    """``seq`` at ``fps`` (linear interpolation of joints, nearest frame for labels, tags, contacts),
    played ``speed`` times as fast. NaN joints stay unknown wherever a neighbour is unknown."""
    if fps <= 0 or speed <= 0:
        raise ValueError(f"fps and speed must be positive, got {fps}, {speed}")
    if abs(fps - seq.fps) < 1e-9 and speed == 1.0:
        return seq
    n = len(seq)
    duration = (n - 1) / seq.fps / speed
    m = max(1, int(np.floor(duration * fps + 1e-9)) + 1)
    src = np.arange(m) / fps * speed * seq.fps  # fractional source frame of each new frame
    lo = np.clip(np.floor(src).astype(int), 0, n - 1)
    hi = np.clip(lo + 1, 0, n - 1)
    w = (src - lo)[:, None, None]
    j = seq.joints_m
    joints = (1 - w) * j[lo] + w * j[hi]  # NaN on either side -> NaN
    near = np.clip(np.rint(src).astype(int), 0, n - 1)
    return LabelledSequence(
        joints,
        float(fps),
        seq.labels[near],
        seq.tags[near],
        None if seq.contacts is None else seq.contacts[near],
        seq.source,
        seq.name if speed == 1.0 else f"{seq.name}@x{speed:.2f}",
    )


def mirrored(seq: LabelledSequence) -> LabelledSequence:
    """The mirror image through the CAVE's x = 0 plane: left and right joints, feet and side-step
    labels swapped (a mirrored left side step is a right one)."""
    j = seq.joints_m.copy()
    j[..., 0] *= -1.0
    for a, b in FLIP_PAIRS:
        j[:, [a, b]] = j[:, [b, a]]
    labels = seq.labels.copy()
    labels[seq.labels == _LEFT] = _RIGHT
    labels[seq.labels == _RIGHT] = _LEFT
    contacts = None if seq.contacts is None else seq.contacts[:, ::-1].copy()
    return LabelledSequence(j, seq.fps, labels, seq.tags, contacts, seq.source, f"{seq.name}/mirror")


def from_folder(path: str | Path, source: str | None = None) -> list[LabelledSequence]:
    """Every ``*.npz`` under ``path`` (sorted), checked; ``source`` overrides the files' own."""
    root = Path(path)
    if not root.is_dir():
        raise InputError(f"not a folder of labelled skeleton files: {root}")
    files = sorted(root.rglob("*.npz"))
    if not files:
        raise InputError(f"{root}: no .npz files")
    out = []
    for p in files:
        seq = load_labelled(p)
        if source is not None:
            seq = LabelledSequence(
                seq.joints_m, seq.fps, seq.labels, seq.tags, seq.contacts, source, seq.name
            )
        out.append(seq)
    return out


def simulated(
    count: int,
    duration_s: float,
    fps: float,
    seed: int,
    start_radius_m: float = 0.7,
    progress: Callable[[str], None] | None = None,
    kinds: tuple[str, ...] = ("mixed",),
    source: str = "sim",
) -> list[LabelledSequence]:
    """Routines of our own simulator (``pipeline.sim.routines.simulate_routine``: a random person
    doing a random routine of a kind), the kinds taken in turn; labelled sequences named
    ``{source}-{seed}-{i}``. Routine i's person comes from (seed, i)."""
    from pipeline.sim.routines import simulate_routine

    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        r = start_radius_m * np.sqrt(rng.random())
        a = rng.uniform(0, 2 * np.pi)
        kind = kinds[i % len(kinds)]
        routine_seed = int(np.random.SeedSequence([int(seed), i, 0x51]).generate_state(1)[0])
        motion = simulate_routine(
            routine_seed, duration_s, kind, fps=fps, start_xy_m=(r * np.cos(a), r * np.sin(a))
        )
        seq = from_skeleton(motion.to_sequence(), source, f"{source}-{seed}-{i:04d}-{kind}")
        out.append(
            LabelledSequence(seq.joints_m, seq.fps, seq.labels, seq.tags, seq.contacts, source, seq.name)
        )
        if progress is not None and ((i + 1) % 50 == 0 or i + 1 == count):
            progress(f"{source}: simulated {i + 1}/{count} routines")
    return out


def gait_model(
    count: int,
    duration_s: float,
    fps: float,
    seed: int,
    progress: Callable[[str], None] | None = None,
    source: str = "gait",
) -> list[LabelledSequence]:
    """Routines of the second motion model (``pipeline.sim.gait``, joint-angle curves), clean;
    routine i's seed comes from (seed, i)."""
    from pipeline.sim.gait import GaitConfig, generate_routine

    config = GaitConfig(fps=fps, duration_s=duration_s)
    out = []
    for i in range(count):
        routine_seed = int(np.random.SeedSequence([int(seed), i, 0x6A]).generate_state(1)[0])
        seq = from_skeleton(generate_routine(config, routine_seed), source, f"{source}-{seed}-{i:04d}")
        out.append(
            LabelledSequence(seq.joints_m, seq.fps, seq.labels, seq.tags, seq.contacts, source, seq.name)
        )
        if progress is not None and ((i + 1) % 10 == 0 or i + 1 == count):
            progress(f"{source}: generated {i + 1}/{count} routines")
    return out


# Independent motion models that train (other seeds than their held-out sets)
INDEPENDENT_MODELS = ("blind", "blind2", "blind3")
_SEED_TAGS = {"blind": 0xB1, "blind2": 0xB2, "blind3": 0xB3}


def training_seed(model: str, seed: int) -> int:
    """The seed of ``model``'s training sequences for a network's ``seed``: drawn from it, and never
    a seed of ``model``'s held-out sets (``pipeline.mocap.sources.BLIND_SETS``)."""
    from pipeline.mocap.sources import BLIND_SETS

    held = {s.seed for s in BLIND_SETS.values() if s.model == model}
    out = int(np.random.SeedSequence([int(seed), _SEED_TAGS[model]]).generate_state(1)[0])
    while out in held:  # (a 1 in 4e9 draw; the held-out set must stay unseen)
        out += 1
    return out


def independent_model(
    model: str,
    count: int,
    duration_s: float,
    seed: int,
    progress: Callable[[str], None] | None = None,
    source: str | None = None,
) -> list[LabelledSequence]:
    """Clean sequences (no noise, no lost joints: the training capture adds its own) of the third
    (``blind``, :mod:`pipeline.sim.blind`), fourth (``blind2``, :mod:`pipeline.sim.blind2`) or fifth
    (``blind3``, :mod:`pipeline.sim.blind3`) motion model, drawn from a seed derived from ``seed``
    (never their held-out sets' seeds), read back through their NPZ files exactly as a folder
    source; named ``{source}-{seed}-{i}``."""
    import tempfile

    if model not in INDEPENDENT_MODELS:
        raise InputError(f"an independent motion model is one of {INDEPENDENT_MODELS}, got {model!r}")
    source = source or model
    model_seed = training_seed(model, seed)
    with tempfile.TemporaryDirectory(prefix=f"cavewalk-{model}-") as tmp:
        if model == "blind":
            from pipeline.sim import blind

            blind.write_set(tmp, count, duration_s, model_seed, noise_m=0.0, dropout=0.0)
        elif model == "blind3":
            from pipeline.sim import blind3

            for i in range(count):
                g, joints = blind3.generate_clean(model_seed, i, duration_s, blind3.FPS)
                np.savez(Path(tmp) / blind3.file_name(model_seed, i), **blind3.record(g, joints))  # type: ignore[arg-type]
        else:
            from pipeline.sim.blind2.generate import SetConfig, generate_set, save_set

            config = SetConfig(count=count, seed=model_seed, duration_s=duration_s)
            clean = [replace(g, joints_m=g.clean.joints_m.astype(np.float32)) for g in generate_set(config)]
            save_set(tmp, clean, model_seed)
        seqs = from_folder(tmp, source=source)
    if progress is not None:
        progress(f"{source}: generated {len(seqs)} routines of {model} (seed {model_seed})")
    return [
        LabelledSequence(s.joints_m, s.fps, s.labels, s.tags, s.contacts, source, f"{source}-{seed}-{i:04d}")
        for i, s in enumerate(seqs)
    ]


def from_skeleton(seq: SkeletonSequence, source: str, name: str) -> LabelledSequence:
    """A :class:`pipeline.skeleton.SkeletonSequence` with labels as a labelled sequence."""
    joints = np.asarray(seq.joints_m, dtype=np.float64)
    labels = seq.labels
    if labels is None:
        raise InputError(f"{name}: the sequence has no labels")
    n = joints.shape[0]
    tags, contacts, own = seq.tags, seq.contacts, seq.source
    return LabelledSequence(
        np.where(np.isfinite(joints), joints, np.nan),
        float(seq.fps),
        encode_labels(list(labels), where=name),
        np.asarray(tags if tags is not None else [""] * n, dtype=str),
        None if contacts is None else np.asarray(contacts, dtype=bool),
        str(own) if own else source,
        name,
    )


def label_counts(seqs: Iterable[LabelledSequence]) -> dict[str, int]:
    """Frames per label over many sequences (ignore included)."""
    counts = dict.fromkeys((*ACTIONS, "ignore"), 0)
    for s in seqs:
        for i, name in enumerate(ACTIONS):
            counts[name] += int(np.sum(s.labels == i))
        counts["ignore"] += int(np.sum(s.labels == IGNORE_INDEX))
    return counts


def check_joints(joints: NDArray[np.floating]) -> None:
    if np.asarray(joints).ndim != 3 or np.asarray(joints).shape[1:] != (NUM_JOINTS, 3):
        raise ValueError(f"joints must be (T, {NUM_JOINTS}, 3), got {np.asarray(joints).shape}")
