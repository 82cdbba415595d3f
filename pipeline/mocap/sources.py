"""Named training / evaluation sources on disk, one folder per source (``NAME=DIR`` of
:class:`pipeline.recognition.prepare.SourceSpec`).

Layout, under ``<cache_dir>/data/sources/``::

    sources.json            per source: dir, use, licence(s), origin, clips, frames per label
    mocap-<package>/*.npz   the real clips of one package (pipeline.mocap), all of one ``use``
    gait/*.npz              the second motion model (pipeline.sim.gait), training set
    still/*.npz             our simulator's still library (pipeline.sim.routines kind "still": crouch,
                            squat, kneel, bend, lean, tiptoe, jump, sway, dance, weight shifts,
                            stretches, gestures, turns; every frame still), training set
    still-heldout/*.npz     the same with other seeds (evaluation)
    gait-heldout/*.npz      the gait model's in-place preset (marching, side steps out-and-back and
                            step-touch, gestures, turns, standing) with other seeds, 1.2 cm noise,
                            2 % dropped joints, bodies 1.48-1.98 m (never trained on: evaluation)
    blind-heldout/*.npz     the third motion model (pipeline.sim.blind, written without reading the
                            other two): marching, side steps out-and-back / step-touch / shuffle,
                            standing behaviours and pivot turns, 1.2 cm noise, 2 % dropped joints,
                            bodies 1.48-1.98 m (evaluation only; the action model trains on other
                            seeds of its generator)
    blind2-heldout/*.npz    the fourth motion model (pipeline.sim.blind2): the same kinds of motion,
                            with its own noise (evaluation only; trained on with other seeds)
    blind3-heldout/*.npz    the fifth (pipeline.sim.blind3), likewise (evaluation only; trained on
                            with other seeds)
    blind4-heldout/*.npz    the sixth (pipeline.sim.blind4: an inverted-pendulum centre of mass over
                            planned footsteps), evaluation only and never trained on at all
    blind5-heldout/*.npz    the seventh (pipeline.sim.blind5: keyframe animation on a joint hierarchy
                            with foot-lock IK; adds aerobics step-touches, crouches and tiptoes),
                            evaluation only and never trained on at all
    blind6-heldout/*.npz    the eighth (pipeline.sim.blind6: coupled Hopf oscillators drive the
                            rhythm; adds dancing, jumps, kneeling, squats, leans and picking up),
                            evaluation only and never trained on at all
    blind7-heldout/*.npz    the ninth (pipeline.sim.blind7: a linear-inverted-pendulum centre of mass
                            driven by a capture-point plan through planned footsteps, minimum-jerk
                            swing feet, two-link leg IK), evaluation only and never trained on at all

``use``: ``train`` (may be trained on and held out by leave-one-source-out), or ``eval``
(held-out evaluation only: never pass it to ``train_action.py``). A source folder never mixes
the two: a package whose clips differ in ``use`` gets ``mocap-<package>`` and
``mocap-<package>-eval``. The NPZs are copies of the clips in ``data/mocap`` (small).
"""

from __future__ import annotations

import json
import shutil
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.errors import InputError
from pipeline.mocap.fetch import fetch_mocap, mocap_dir
from pipeline.skeleton import LABELS, load_npz, save_npz

MANIFEST = "sources.json"
GAIT_TRAIN_SEED = 0
GAIT_HELDOUT_SEED = 1_000_003  # far from any training seed


@dataclass(frozen=True, slots=True)
class GaitSet:
    """A set of gait-model routines: how many, how long, seed, noise, dropout, heights."""

    count: int
    duration_s: float
    seed: int
    noise_m: float = 0.0
    dropout: float = 0.0
    height_m: tuple[float, float] = (1.40, 2.05)
    preset: str = "default"  # "default" (every behaviour) or "in-place" (pipeline.sim.gait.IN_PLACE_MIX)

    def __post_init__(self) -> None:
        if self.count < 1 or not self.duration_s > 0:
            raise InputError(
                f"a gait set needs count >= 1 and a positive duration, got {self.count}, {self.duration_s}"
            )


GAIT_SETS = {
    "gait": GaitSet(count=24, duration_s=60.0, seed=GAIT_TRAIN_SEED),
    "gait-heldout": GaitSet(
        count=12,
        duration_s=60.0,
        seed=GAIT_HELDOUT_SEED,
        noise_m=0.012,
        dropout=0.02,
        height_m=(1.48, 1.98),
        preset="in-place",
    ),
}
GAIT_USE = {"gait": "train", "gait-heldout": "eval"}


@dataclass(frozen=True, slots=True)
class SimSet:
    """A set of our simulator's routines (pipeline.sim.routines) of one kind."""

    kind: str
    count: int
    duration_s: float
    seed: int

    def __post_init__(self) -> None:
        if self.count < 1 or not self.duration_s > 0:
            raise InputError(
                f"a sim set needs count >= 1 and a positive duration, got {self.count}, {self.duration_s}"
            )


SIM_SETS = {
    "still": SimSet(kind="still", count=36, duration_s=40.0, seed=0),
    "still-heldout": SimSet(kind="still", count=12, duration_s=40.0, seed=2_000_003),
}
SIM_USE = {"still": "train", "still-heldout": "eval"}


BLIND_MODELS = ("blind", "blind2", "blind3", "blind4", "blind5", "blind6", "blind7")
# their generators add their own capture noise
OWN_NOISE_MODELS = ("blind2", "blind3", "blind4", "blind5", "blind6", "blind7")


@dataclass(frozen=True, slots=True)
class BlindSet:
    """A set of an independent motion model's sequences: ``model`` ``blind`` (the third motion model,
    pipeline.sim.blind), ``blind2`` (the fourth, pipeline.sim.blind2), ``blind3`` (the fifth,
    pipeline.sim.blind3), ``blind4`` (the sixth, pipeline.sim.blind4), ``blind5`` (the seventh,
    pipeline.sim.blind5), ``blind6`` (the eighth, pipeline.sim.blind6) or ``blind7`` (the ninth,
    pipeline.sim.blind7; the capture noise of blind2 to blind7 is their own: 1.2 cm and 2 % of the
    joints, so ``noise_m`` and ``dropout`` must stay at those values); how many, how long, seed, noise
    and dropped joints."""

    count: int
    duration_s: float
    seed: int
    noise_m: float = 0.012
    dropout: float = 0.02
    model: str = "blind"

    def __post_init__(self) -> None:
        if self.count < 1 or not self.duration_s > 0:
            raise InputError(
                f"a blind set needs count >= 1 and a positive duration, got {self.count}, {self.duration_s}"
            )
        if self.model not in BLIND_MODELS:
            raise InputError(f"a blind set's model is one of {BLIND_MODELS}, got {self.model!r}")
        if self.model in OWN_NOISE_MODELS and (self.noise_m, self.dropout) != (0.012, 0.02):
            raise InputError(
                f"{self.model} sets have their own capture noise (noise_m 0.012, dropout 0.02), "
                f"got {self.noise_m}, {self.dropout}"
            )


# held-out evaluation only: never trained on (blind4 to blind7 are never trained on at all; blind,
# blind2 and blind3 train with other seeds: corpus.independent_model)
BLIND_SETS = {
    "blind-heldout": BlindSet(count=12, duration_s=60.0, seed=4242),
    "blind2-heldout": BlindSet(count=12, duration_s=60.0, seed=2026, model="blind2"),
    "blind3-heldout": BlindSet(count=12, duration_s=60.0, seed=31337, model="blind3"),
    "blind4-heldout": BlindSet(count=12, duration_s=60.0, seed=60606, model="blind4"),
    "blind5-heldout": BlindSet(count=12, duration_s=60.0, seed=50505, model="blind5"),
    "blind6-heldout": BlindSet(count=12, duration_s=60.0, seed=60606, model="blind6"),
    "blind7-heldout": BlindSet(count=12, duration_s=60.0, seed=70707, model="blind7"),
}
BLIND_ORIGINS = {
    "blind": "pipeline.sim.blind: a third motion model, written without reading the others",
    "blind2": "pipeline.sim.blind2: a fourth motion model, written without reading the product's code",
    "blind3": "pipeline.sim.blind3: a fifth motion model (joint angles and forward kinematics), written "
    "without reading the product's code",
    "blind4": "pipeline.sim.blind4: a sixth motion model (an inverted-pendulum centre of mass over planned "
    "footsteps, inverse-kinematics legs), written without reading the product's code",
    "blind5": "pipeline.sim.blind5: a seventh motion model (keyframe animation on a joint hierarchy, "
    "foot-lock IK), written without reading the product's code",
    "blind6": "pipeline.sim.blind6: an eighth motion model (coupled Hopf oscillators set the rhythm, "
    "forward kinematics, IK legs, a pinned stance foot), written without reading the product's code",
    "blind7": "pipeline.sim.blind7: a ninth motion model (a linear-inverted-pendulum centre of mass driven "
    "by a capture-point plan through planned footsteps, IK legs), written without reading the product's code",
}


def _cached_or_emptied(folder: Path, stamp: dict[str, Any]) -> dict[str, Any] | None:
    """The set's index when ``folder`` holds the set made with ``stamp``; else None, with ``folder``
    emptied (created) for the set to be made again."""
    index_path = folder / "index.json"
    if index_path.is_file():
        old = json.loads(index_path.read_text())
        if old.get("stamp") == stamp and all((folder / f["file"]).is_file() for f in old["files"]):
            return dict(old)
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    return None


def write_sim_set(folder: Path, spec: SimSet, progress: Callable[[str], None]) -> dict[str, Any]:
    """The set's NPZs in ``folder`` (made again only when the set's settings or the simulator's
    version changed)."""
    from pipeline.sim import routines

    stamp = {"kind": spec.kind, "count": spec.count, "duration_s": spec.duration_s, "seed": spec.seed,
             "sim_version": routines.SIM_VERSION, "v": 1}  # fmt: skip
    cached = _cached_or_emptied(folder, stamp)
    if cached is not None:
        return cached
    index_path = folder / "index.json"
    files = []
    for i in range(spec.count):
        seed = spec.seed + i
        seq = routines.simulate_routine(seed=seed, duration_s=spec.duration_s, kind=spec.kind).to_sequence()
        name = f"sim_{spec.kind}_{seed}.npz"
        save_npz(folder / name, seq)
        labels = list(seq.labels or ())
        files.append({"file": name, "seed": seed, "frames_per_label": _frames_per_label(labels),
                      "tags": dict(Counter(t for t in (seq.tags or ()) if t))})  # fmt: skip
        progress(f"  {folder.name}/{name}: {len(labels)} frames")
    index = {"stamp": stamp, "files": files}
    index_path.write_text(json.dumps(index, indent=1))
    return index


def sources_dir(cache_dir: Path) -> Path:
    return cache_dir / "data" / "sources"


def _frames_per_label(labels: list[str]) -> dict[str, int]:
    c = Counter(labels)
    return {lab: int(c.get(lab, 0)) for lab in LABELS}


def write_gait_set(folder: Path, spec: GaitSet, progress: Callable[[str], None]) -> dict[str, Any]:
    """The set's NPZs in ``folder`` (made again only when the set's settings changed)."""
    from pipeline.sim.gait import (
        IN_PLACE_MIX,
        IN_PLACE_SIDE_KINDS,
        MODEL_VERSION,
        BodyConfig,
        GaitConfig,
        simulate_routine,
    )

    stamp = {
        "count": spec.count,
        "duration_s": spec.duration_s,
        "seed": spec.seed,
        "noise_m": spec.noise_m,
        "dropout": spec.dropout,
        "height_m": list(spec.height_m),
        "preset": spec.preset,
        "model_version": MODEL_VERSION,
        "v": 2,
    }
    cached = _cached_or_emptied(folder, stamp)
    if cached is not None:
        return cached
    index_path = folder / "index.json"
    config = GaitConfig(
        duration_s=spec.duration_s,
        noise_m=spec.noise_m,
        dropout=spec.dropout,
        body=BodyConfig(height_min_m=spec.height_m[0], height_max_m=spec.height_m[1]),
    )
    if spec.preset == "in-place":
        config = replace(config, mix=IN_PLACE_MIX, side_kinds=IN_PLACE_SIDE_KINDS)
    files = []
    for i in range(spec.count):
        seed = int(np.random.SeedSequence([spec.seed, i]).generate_state(1)[0])
        take = simulate_routine(config, seed)
        name = f"gait_{spec.seed}_{i:03d}.npz"
        save_npz(folder / name, take.sequence)
        labels = list(take.sequence.labels or ())
        files.append(
            {
                "file": name,
                "seed": seed,
                "height_m": round(take.body.height_m, 3),
                "frames_per_label": _frames_per_label(labels),
                "tags": dict(Counter(t for t in (take.sequence.tags or ()) if t)),
            }
        )
        progress(f"  {folder.name}/{name}: {len(labels)} frames, height {take.body.height_m:.2f} m")
    index = {"stamp": stamp, "files": files}
    index_path.write_text(json.dumps(index, indent=1))
    return index


def write_blind_set(folder: Path, spec: BlindSet, progress: Callable[[str], None]) -> dict[str, Any]:
    """The set's NPZs in ``folder`` (made again only when the set's settings changed)."""
    import importlib

    from pipeline.sim import blind, blind2

    stamp: dict[str, Any] = {"count": spec.count, "duration_s": spec.duration_s, "seed": spec.seed,
                             "noise_m": spec.noise_m, "dropout": spec.dropout, "v": 1}  # fmt: skip
    if spec.model != "blind":
        stamp["model"] = spec.model  # (the blind sets' stamps stay as they were: no remake)
    cached = _cached_or_emptied(folder, stamp)
    if cached is not None:
        return cached
    files = []
    if spec.model == "blind2":
        config = blind2.SetConfig(count=spec.count, seed=spec.seed, duration_s=spec.duration_s)
        paths = blind2.write_set(folder, config)
    elif spec.model != "blind":  # blind3 to blind7: write_set(folder, count, seed, duration_s)
        model = importlib.import_module(f"pipeline.sim.{spec.model}")
        paths = model.write_set(folder, spec.count, spec.seed, spec.duration_s)
    else:
        paths = blind.write_set(folder, spec.count, spec.duration_s, spec.seed, spec.noise_m, spec.dropout)
    for path in paths:
        seq = load_npz(path)
        labels = list(seq.labels or ())
        files.append({"file": path.name, "frames_per_label": _frames_per_label(labels),
                      "tags": dict(Counter(t for t in (seq.tags or ()) if t))})  # fmt: skip
        progress(f"  {folder.name}/{path.name}: {len(labels)} frames")
    index = {"stamp": stamp, "files": files}
    (folder / "index.json").write_text(json.dumps(index, indent=1))
    return index


def _generated_entry(
    folder: Path, index: dict[str, Any], use: str, kind: str, package: str, origin: str
) -> dict[str, Any]:
    """The manifest's entry of a generated set (its ``write_*_set`` index)."""
    totals: Counter[str] = Counter()
    for f in index["files"]:
        totals.update(f["frames_per_label"])
    return {
        "dir": str(folder),
        "use": use,
        "kind": kind,
        "licences": [f"generated by this repository ({package})"],
        "data_origin": [origin],
        "clips": [f["file"] for f in index["files"]],
        "fps": 30.0,
        "settings": index["stamp"],
        "frames_per_label": {lab: int(totals.get(lab, 0)) for lab in LABELS},
    }


def write_sources(
    cache_dir: Path,
    progress: Callable[[str], None] = print,
    gait_sets: dict[str, GaitSet] | None = None,
    sim_sets: dict[str, SimSet] | None = None,
    blind_sets: dict[str, BlindSet] | None = None,
) -> dict[str, dict[str, Any]]:
    """Make every named source folder exist; returns (and writes) the manifest."""
    root = sources_dir(cache_dir)
    root.mkdir(parents=True, exist_ok=True)
    fetch_mocap(cache_dir, progress=progress)
    index = json.loads((mocap_dir(cache_dir) / "index.json").read_text())
    manifest: dict[str, dict[str, Any]] = {}
    by_pkg_use: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for c in index["clips"]:
        by_pkg_use.setdefault((c["package"].split("==")[0], c["use"]), []).append(c)
    mixed = {pkg for pkg, _ in by_pkg_use if sum(1 for p, _ in by_pkg_use if p == pkg) > 1}
    for (pkg, use), clips in sorted(by_pkg_use.items()):
        name = f"mocap-{pkg}" + ("-eval" if pkg in mixed and use == "eval" else "")
        folder = root / name
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir(parents=True)
        totals: Counter[str] = Counter()
        for c in clips:
            shutil.copy2(mocap_dir(cache_dir) / c["file"], folder / c["file"])
            totals.update(c["frames_per_label"])
        manifest[name] = {
            "dir": str(folder),
            "use": use,
            "kind": "mocap",
            "package": clips[0]["package"],
            "licences": sorted({c["licence"] for c in clips}),
            "data_origin": sorted({c["data_origin"] for c in clips}),
            "clips": [c["id"] for c in clips],
            "fps": index["fps"],
            "frames_per_label": {lab: int(totals.get(lab, 0)) for lab in LABELS},
        }
    for name, spec in (gait_sets if gait_sets is not None else GAIT_SETS).items():
        progress(f"gait model set {name}: {spec.count} x {spec.duration_s:g} s (seed {spec.seed})")
        gi = write_gait_set(root / name, spec, progress)
        manifest[name] = _generated_entry(
            root / name, gi, GAIT_USE.get(name, "train"), "gait-model", "pipeline.sim.gait",
            "pipeline.sim.gait: published joint-angle curves (Winter, Novacheck, Perry)",
        )  # fmt: skip
    for name, sim in (sim_sets if sim_sets is not None else SIM_SETS).items():
        progress(
            f"simulator set {name}: {sim.count} x {sim.duration_s:g} s of kind {sim.kind} (seed {sim.seed})"
        )
        si = write_sim_set(root / name, sim, progress)
        manifest[name] = _generated_entry(
            root / name, si, SIM_USE.get(name, "train"), "simulator", "pipeline.sim",
            f"pipeline.sim.routines kind {sim.kind} (pipeline.sim.behaviours)",
        )  # fmt: skip
    for name, blind in (blind_sets if blind_sets is not None else BLIND_SETS).items():
        progress(
            f"independent motion model ({blind.model}) set {name}: "
            f"{blind.count} x {blind.duration_s:g} s (seed {blind.seed})"
        )
        bi = write_blind_set(root / name, blind, progress)
        manifest[name] = _generated_entry(
            root / name, bi, "eval", "blind-model", f"pipeline.sim.{blind.model}", BLIND_ORIGINS[blind.model]
        )
    (root / MANIFEST).write_text(json.dumps(manifest, indent=1))
    return manifest


def evaluation_only(folder: Path) -> str | None:
    """The name of the held-out source ``folder`` is, if the manifest beside it (the ``sources.json``
    of ``cavewalk data sources``) lists it for evaluation only (``use`` ``eval``); else None."""
    path = Path(folder).resolve()
    manifest = path.parent / MANIFEST
    if not manifest.is_file():
        return None
    try:
        data = json.loads(manifest.read_text())
    except (OSError, ValueError):
        return None
    for name, entry in data.items() if isinstance(data, dict) else ():
        if (
            isinstance(entry, dict)
            and entry.get("use") == "eval"
            and Path(str(entry.get("dir", ""))).resolve() == path
        ):
            return str(name)
    return None


def load_sources(cache_dir: Path) -> dict[str, dict[str, Any]]:
    """The manifest :func:`write_sources` wrote (raises :class:`InputError` if absent)."""
    path = sources_dir(cache_dir) / MANIFEST
    if not path.is_file():
        raise InputError(f"no source manifest at {path}; run `cavewalk data sources` first")
    data: dict[str, dict[str, Any]] = json.loads(path.read_text())
    return data
