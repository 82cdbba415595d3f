"""The training corpus prepared: every source's sequences augmented, captured and with step evidence.

``sources`` are ``sim`` (our simulator's random routines) or ``NAME=DIR`` (labelled SPEC NPZ
files). Each sequence is brought to 30 fps, mirrored, sources marked ``warp`` (recordings)
are also played at 0.85x and 1.15x (cadences the recordings did not have), then seen by the
simulated CAVE cameras and triangulated back (:func:`train.capture`), and run through the step
tracker (the evidence channels, exactly as at run time). The result is cached (one pickle per configuration).

An :class:`Item` keeps the clip it came from (``group``), so that a validation split or a
leave-one-source-out fold never has an augmentation of a clip on both sides.
"""

from __future__ import annotations

import hashlib
import json
import pickle
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.recognition import corpus
from pipeline.recognition.dataset import LabelledSequence
from pipeline.recognition.features import evidence_vector
from pipeline.recognition.steps import StepConfig, StepTracker
from pipeline.recognition.train import Dataset, NoiseConfig, captured

FPS = 30.0
_NOT_IN_EVIDENCE = ("max_tilt_deg",)  # step settings the evidence channels do not depend on
WARP_SPEEDS = (0.85, 1.0, 1.15)


GENERATORS = ("sim", "gait", *corpus.INDEPENDENT_MODELS)
DEFAULT_SIM_KINDS = ("stepping",)


@dataclass(frozen=True, slots=True)
class SourceSpec:
    """A source of labelled sequences: a generator or a named folder of labelled NPZ files.

    Forms of :meth:`parse`: ``sim`` (our simulator's stepping routines), ``NAME=sim:KIND+KIND``
    (routines of those kinds, e.g. ``still=sim:still``), ``gait`` / ``NAME=gait`` (the second
    motion model), ``blind`` / ``blind2`` / ``blind3`` / ``NAME=blind`` ... (the third to fifth
    motion models, clean, other seeds than their held-out sets), any of them with ``@COUNT``
    (routines; default the command's ``--sequences``), or ``NAME=DIR`` (every labelled NPZ under DIR).
    """

    name: str
    folder: Path | None = None
    warp: bool = False  # also played at 0.85x and 1.15x (recordings with few cadences)
    generator: str = ""  # one of GENERATORS when folder is None
    kinds: tuple[str, ...] = ()
    count: int | None = None

    @classmethod
    def parse(cls, text: str, warp: bool = False) -> SourceSpec:
        body, at, count_text = text.partition("@")
        count: int | None = None
        if at:
            try:
                count = int(count_text)
            except ValueError:
                count = -1
            if count < 1:
                raise InputError(f"a source's @COUNT must be a positive integer, got {text!r}")
        if body in GENERATORS:
            kinds: tuple[str, ...] = DEFAULT_SIM_KINDS if body == "sim" else ()
            return cls(body, None, warp, body, kinds, count)
        name, sep, rest = body.partition("=")
        if not sep or not name or not rest:
            named = ", ".join(f"NAME={g}" for g in GENERATORS if g != "sim")
            raise InputError(
                f"a source is {', '.join(repr(g) for g in GENERATORS)}, NAME=sim:KINDS, {named} or NAME=DIR, "
                f"got {text!r}"
            )
        if rest in GENERATORS and rest != "sim":
            return cls(name, None, warp, rest, (), count)
        if rest.startswith("sim:") or rest == "sim":
            from pipeline.sim.ranges import ROUTINE_KINDS

            kinds = tuple(k for k in rest[4:].split("+") if k) or DEFAULT_SIM_KINDS
            bad = [k for k in kinds if k not in ROUTINE_KINDS]
            if bad:
                raise InputError(
                    f"unknown routine kinds {bad} in {text!r}; known: {', '.join(ROUTINE_KINDS)}"
                )
            return cls(name, None, warp, "sim", kinds, count)
        if at:
            raise InputError(f"@COUNT is for generated sources, not a folder: {text!r}")
        return cls(name, Path(rest), warp)

    def fingerprint(self) -> str:
        """What the source's data depends on: a generator's name and kinds (our simulator's also its
        ``SIM_VERSION``, so a prepared cache of an older simulator is not used), or a folder's files."""
        if self.folder is None:
            from pipeline.sim.routines import SIM_VERSION

            version = f"@v{SIM_VERSION}" if self.generator == "sim" else ""
            return f"{self.generator}:{'+'.join(self.kinds)}{version}"
        h = hashlib.sha1()
        for p in sorted(self.folder.rglob("*.npz")):
            st = p.stat()
            h.update(f"{p.relative_to(self.folder)}:{st.st_size}:{int(st.st_mtime)}".encode())
        return h.hexdigest()[:10]


@dataclass(frozen=True, slots=True)
class Item:
    """One prepared sequence: captured (float32 joints), its evidence (T, 16), where it came from.

    original: not mirrored and at its own speed (what a held-out evaluation uses).
    """

    group: str
    seq: LabelledSequence
    evidence: NDArray[np.float32]
    original: bool


def clean_sequences(
    sources: Sequence[SourceSpec], sim_count: int, sim_duration_s: float, seed: int,
    progress: Callable[[str], None] | None = None,
) -> list[tuple[str, LabelledSequence, bool]]:  # fmt: skip
    """(group, sequence at 30 fps, original?) for every source and its augmentations."""
    out: list[tuple[str, LabelledSequence, bool]] = []
    for src in sources:
        n_gen = src.count or sim_count
        speeds: tuple[float, ...] = (1.0,)
        if src.folder is None and src.generator == "gait":
            base = corpus.gait_model(n_gen, sim_duration_s, FPS, seed, progress=progress, source=src.name)
        elif src.folder is None and src.generator in corpus.INDEPENDENT_MODELS:
            base = corpus.independent_model(
                src.generator, n_gen, sim_duration_s, seed, progress=progress, source=src.name
            )
        elif src.folder is None:
            kinds = src.kinds or DEFAULT_SIM_KINDS
            base = corpus.simulated(
                n_gen, sim_duration_s, FPS, seed, progress=progress, kinds=kinds, source=src.name
            )
        else:
            base = corpus.from_folder(src.folder, source=src.name)
            speeds = WARP_SPEEDS if src.warp else (1.0,)
        n0 = len(out)
        for s in base:
            group = f"{src.name}:{s.name}"
            for sp in speeds:
                r = corpus.resample(s, FPS, speed=sp)
                out += [(group, r, sp == 1.0), (group, corpus.mirrored(r), False)]
        if progress is not None:
            progress(f"source {src.name}: {len(base)} sequences, {len(out) - n0} with augmentations")
    return out


def evidence_of(seq: LabelledSequence, steps: StepConfig | None = None) -> NDArray[np.float32]:
    """(T, 16) evidence channels of a sequence, from the run-time step tracker."""
    tracker = StepTracker(replace(steps or StepConfig(), rate_hz=seq.fps))
    return np.stack([evidence_vector(tracker.update(f, k / seq.fps)) for k, f in enumerate(seq.joints_m)])


def prepare_corpus(
    sources: Sequence[SourceSpec],
    cache_dir: Path,
    sim_count: int = 360,
    sim_duration_s: float = 40.0,
    seed: int = 0,
    noise: NoiseConfig | None = None,
    progress: Callable[[str], None] | None = None,
    steps: StepConfig | None = None,
) -> list[Item]:
    """Every source prepared (see the module docstring); each source cached on its own in ``cache_dir``
    (adding a source later prepares only that one). ``steps``: the step tracker of the evidence
    channels (default: the run-time one)."""
    items: list[Item] = []
    for src in sources:
        items += prepare_source(src, cache_dir, sim_count, sim_duration_s, seed, noise, progress, steps)
    return items


def prepare_source(
    src: SourceSpec,
    cache_dir: Path,
    sim_count: int = 360,
    sim_duration_s: float = 40.0,
    seed: int = 0,
    noise: NoiseConfig | None = None,
    progress: Callable[[str], None] | None = None,
    steps: StepConfig | None = None,
) -> list[Item]:
    """One source prepared, from ``cache_dir`` when done before."""
    noise = noise or NoiseConfig()
    steps = steps or StepConfig()
    key = {
        "source": (src.name, str(src.folder), src.fingerprint(), src.warp),
        "sim": (src.count or sim_count, sim_duration_s) if src.folder is None else None,
        "seed": seed,
        "noise": asdict(noise),
        "steps": {k: v for k, v in asdict(steps).items() if k not in _NOT_IN_EVIDENCE},
        "v": 7,
    }
    digest = hashlib.sha1(json.dumps(key, sort_keys=True, default=str).encode()).hexdigest()[:12]
    path = Path(cache_dir) / f"action-source-{src.name}-{digest}.pkl"
    if path.is_file():
        with path.open("rb") as fh:
            cached: list[Item] = pickle.load(fh)
        if progress is not None:
            progress(f"source {src.name}: {len(cached)} prepared sequences from {path}")
        return cached
    pairs = clean_sequences([src], sim_count, sim_duration_s, seed, progress)
    capture_seed = seed + 1 + int(hashlib.sha1(src.name.encode()).hexdigest()[:6], 16)
    seqs = captured([s for _, s, _ in pairs], noise, seed=capture_seed)
    items = []
    t0 = time.monotonic()
    for i, ((group, _, original), seq) in enumerate(zip(pairs, seqs, strict=True)):
        seq32 = replace(seq, joints_m=seq.joints_m.astype(np.float32))
        items.append(Item(group, seq32, evidence_of(seq, steps), original))
        if progress is not None and ((i + 1) % 100 == 0 or i + 1 == len(seqs)):
            progress(
                f"{src.name}: captured + step evidence {i + 1}/{len(seqs)} ({time.monotonic() - t0:.0f} s)"
            )
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as fh:
        pickle.dump(items, fh, protocol=4)
    return items


def to_dataset(items: Sequence[Item]) -> Dataset:
    """Concatenate prepared items into a training :class:`Dataset`."""
    if not items:
        raise ValueError("no sequences")
    lengths = [len(it.seq) for it in items]
    return Dataset(
        np.concatenate([it.seq.joints_m for it in items]).astype(np.float32),
        np.concatenate([it.seq.labels for it in items]).astype(np.int64),
        np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64),
        float(items[0].seq.fps),
        np.concatenate([it.evidence for it in items]).astype(np.float32),
        tuple(it.seq.source for it in items),
    )


def split_items(items: Sequence[Item], fraction: float, seed: int) -> tuple[list[Item], list[Item]]:
    """(train, validation): a share of the clips of every source, their augmentations with them."""
    rng = np.random.default_rng(seed)
    by_source: dict[str, list[str]] = {}
    for g in sorted({it.group for it in items}):
        by_source.setdefault(g.split(":", 1)[0], []).append(g)
    val: set[str] = set()
    for members in by_source.values():
        k = round(len(members) * fraction) if len(members) > 2 else 0
        if k:
            val |= set(rng.choice(members, size=k, replace=False).tolist())
    if not val:  # every source too small: one clip of the largest source
        largest = max(by_source.values(), key=len)
        val = {largest[0]}
    return [it for it in items if it.group not in val], [it for it in items if it.group in val]
