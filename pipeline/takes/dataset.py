"""Recorded takes as labelled sequences: what training, evaluation and teach read.

A take folder (SPEC.md "Takes") holds ``skeletons.npz`` with the participant's ``joints`` and
``labels`` (from the protocol, or corrected in the label editor). :func:`load_take` reads one and
checks it (a take without labels, or whose labels are all ``ignore``, is refused with one clear
message); :func:`take_folders` expands arguments that name a take or a folder of takes.
:func:`write_take` writes a labelled sequence (the simulator's, converted motion capture) as a take
folder through the takes' own file functions, so every consumer reads one format.
"""

from __future__ import annotations

import json
import math
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.errors import InputError
from pipeline.recognition.dataset import IGNORE_INDEX, LabelledSequence, encode_labels
from pipeline.skeleton import NUM_JOINTS
from pipeline.takes.files import (
    FRAMES,
    MANIFEST,
    SKELETONS,
    finish_take,
    load_manifest,
    write_json,
    write_spans,
)
from pipeline.takes.protocol import LabelSpan


@dataclass(frozen=True, slots=True)
class TakeData:
    """One take's participant sequence: its uid, the participant (code, else the take's id), the frames."""

    uid: str
    participant: str
    seq: LabelledSequence
    folder: Path


def take_folders(paths: list[Path]) -> list[Path]:
    """Each path is a take folder (it has ``take.json``) or a folder of take folders."""
    out: list[Path] = []
    for p in paths:
        p = Path(p)
        if (p / MANIFEST).is_file():
            out.append(p)
        elif p.is_dir():
            found = sorted(d for d in p.iterdir() if (d / MANIFEST).is_file())
            if not found:
                raise InputError(f"{p}: neither a take folder (no {MANIFEST}) nor a folder of takes")
            out += found
        else:
            raise InputError(f"take folder not found: {p}")
    return out


def load_take(folder: Path) -> TakeData:
    """The participant's labelled sequence of a take; :class:`InputError` naming what is wrong."""
    folder = Path(folder)
    manifest = load_manifest(folder)
    uid = str(manifest.get("id"))
    if manifest.get("status") == "recording":
        raise InputError(f"take {uid} is still recording")
    path = folder / SKELETONS
    if not path.is_file() or not zipfile.is_zipfile(path):
        raise InputError(f"take {uid}: {SKELETONS} is missing or not an NPZ file ({folder})")
    with np.load(path, allow_pickle=False) as z:
        keys = set(z.files)
        if "joints" not in keys:
            raise InputError(f"take {uid}: nobody was tracked (no joints in {SKELETONS})")
        if "labels" not in keys:
            raise InputError(
                f"take {uid} has no labels: record it with a protocol or label it in the label editor "
                f"(GET/PUT /api/v1/takes/ID/labels) before training on it"
            )
        joints = np.asarray(z["joints"], dtype=np.float64)
        labels_raw = np.asarray(z["labels"]).astype(str)
        t = np.asarray(z["t"], dtype=np.float64) if "t" in keys else None
        fps = float(np.asarray(z["fps"]).reshape(())) if "fps" in keys else 0.0
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3) or len(joints) < 2:
        raise InputError(f"take {uid}: joints must be (T >= 2, {NUM_JOINTS}, 3), got {joints.shape}")
    if labels_raw.shape != (len(joints),):
        raise InputError(f"take {uid}: {len(labels_raw)} labels for {len(joints)} frames")
    labels = encode_labels(labels_raw, where=f"take {uid}")
    if not np.any(labels != IGNORE_INDEX):
        raise InputError(f"take {uid} has no labels: every frame is 'ignore'; label it before training on it")
    if t is not None and len(t) == len(joints) and np.isfinite(t[[0, -1]]).all() and t[-1] > t[0]:
        fps = (len(t) - 1) / (t[-1] - t[0])
    if not (math.isfinite(fps) and fps > 0):
        raise InputError(f"take {uid}: no frame rate (fps or t) in {SKELETONS}")
    joints = np.where(np.isfinite(joints), joints, np.nan)
    code = manifest.get("participant_code")
    participant = str(code) if code else f"take-{uid}"
    seq = LabelledSequence(
        joints, float(fps), labels, np.full(len(joints), "", dtype="<U1"), None, "takes", uid
    )
    return TakeData(uid, participant, seq, folder)


def load_takes(paths: list[Path]) -> list[TakeData]:
    """Every take named (folders of takes expanded), each checked before any work starts."""
    folders = take_folders(paths)
    if not folders:
        raise InputError("give at least one take folder")
    return [load_take(f) for f in folders]


# --------------------------------------------------------------------------------- writing
def _spans_of(seq: LabelledSequence) -> list[LabelSpan]:
    names = seq.label_names
    spans: list[LabelSpan] = []
    start = 0
    for i in range(1, len(names) + 1):
        if i == len(names) or names[i] != names[start]:
            spans.append(
                LabelSpan(
                    round(start / seq.fps, 6), round(i / seq.fps, 6), names[start], None, "protocol", ""
                )
            )
            start = i
    return spans


def write_take(
    folder: Path, seq: LabelledSequence, participant: str, *, user_id: int = 1, notes: str = ""
) -> dict[str, Any]:
    """Write a labelled sequence as a finished take folder (``frames.jsonl``, ``labels.csv``,
    ``skeletons.npz``, ``take.json`` with checksums); returns its manifest."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=False)
    manifest = {
        "id": folder.name,
        "participant_code": participant,
        "session_id": None,
        "source": "file",
        "notes": notes or f"written from {seq.name or 'a labelled sequence'}",
    }
    write_json(folder / MANIFEST, manifest)
    with (folder / FRAMES).open("w", encoding="utf-8") as f:
        for i, frame in enumerate(seq.joints_m):
            joints = [None if not np.isfinite(j).all() else [round(float(v), 5) for v in j] for j in frame]
            obj = {
                "frame": i,
                "t": round(i / seq.fps, 6),
                "views": [],
                "people3d": [{"user_id": user_id, "joints": joints, "reproj_px": None}],
                "navigator": user_id,
                "action": None,
            }
            f.write(json.dumps(obj, separators=(",", ":")) + "\n")
    write_spans(folder, _spans_of(seq))
    return finish_take(folder, complete=True, manifest=manifest)


# ------------------------------------------------------------------- simulated participants
#: Unusual ways of stepping (the simulator's extremes), as overrides of every stepping segment;
#: ``height_m``: the body's stature (the ends of the simulator's 1.40-2.05 m range).
EXTREME_STYLES: dict[str, dict[str, Any]] = {
    "tiny-shuffle": {
        "knee_lift_m": 0.03,
        "step_width_m": 0.08,
        "cadence_steps_per_s": 1.0,
        "arm_swing_deg": 0.0,
    },
    "high-knees-fast": {"knee_lift_m": 0.32, "step_width_m": 0.5, "cadence_steps_per_s": 2.6},
    "slow-with-pauses": {"cadence_steps_per_s": 0.6, "pause_prob": 0.5, "pause_s": (0.6, 1.0)},
    "irregular-asymmetric": {"irregularity": 0.6, "asymmetry": 2.0, "knee_lift_m": 0.08},
    "short-low-lift": {"height_m": 1.40, "knee_lift_m": 0.04, "step_width_m": 0.12},
    "tall-wide": {"height_m": 2.05, "knee_lift_m": 0.25, "step_width_m": 0.55, "cadence_steps_per_s": 1.2},
}


def simulated_participant(protocol: Any, style: dict[str, Any], seed: int, fps: float = 30.0,
                          captured_noise: bool = True) -> LabelledSequence:  # fmt: skip
    """A simulated person following ``protocol`` (a :class:`~pipeline.takes.protocol.Protocol`) in
    ``style`` (one of :data:`EXTREME_STYLES`), labelled with the simulator's truth, seen by the
    simulated CAVE cameras (pixel noise, triangulation) when ``captured_noise``."""
    from pipeline.recognition.corpus import from_skeleton
    from pipeline.recognition.train import NoiseConfig, captured
    from pipeline.sim.body import sample_body
    from pipeline.sim.motion import simulate_user
    from pipeline.sim.script import STILL_BEHAVIOURS, MotionScript, Segment

    rng = np.random.default_rng(seed)
    height = style.get("height_m")
    body = sample_body(rng, (height, height)) if height else sample_body(rng)
    over = {k: v for k, v in style.items() if k != "height_m"}
    forward = {k: v for k, v in over.items() if k != "step_width_m"}  # a forward step has no width
    segs = []
    for step in protocol.steps:
        if step.label == "still" and step.tag == "turn":
            segs.append(Segment("turn", step.duration_s))
        elif step.label == "still":  # a behaviour of the simulator's still library where the step names one
            behaviour = step.tag if step.tag in STILL_BEHAVIOURS else None
            segs.append(Segment("still", step.duration_s, gestures=(), behaviour=behaviour))
        else:
            segs.append(
                Segment(step.label, step.duration_s, **(forward if step.label == "forward" else over))
            )
    motion = simulate_user(MotionScript(tuple(segs)), body, fps, seed=seed)
    seq = from_skeleton(motion.to_sequence(), "sim", f"sim-{seed}")
    if captured_noise:
        seq = captured([seq], NoiseConfig(), seed)[0]
    return seq
