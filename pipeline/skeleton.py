"""The 17-joint COCO skeleton and skeleton sequences (the NPZ file format of SPEC.md)."""

from __future__ import annotations

import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError

JOINT_NAMES: tuple[str, ...] = (
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
)
NUM_JOINTS = len(JOINT_NAMES)
J = {name: i for i, name in enumerate(JOINT_NAMES)}

# Bones as (parent, child) joint index pairs, used for drawing and bone-length priors.
BONES: tuple[tuple[int, int], ...] = (
    (J["l_shoulder"], J["r_shoulder"]),
    (J["l_hip"], J["r_hip"]),
    (J["l_shoulder"], J["l_hip"]),
    (J["r_shoulder"], J["r_hip"]),
    (J["l_shoulder"], J["l_elbow"]),
    (J["l_elbow"], J["l_wrist"]),
    (J["r_shoulder"], J["r_elbow"]),
    (J["r_elbow"], J["r_wrist"]),
    (J["l_hip"], J["l_knee"]),
    (J["l_knee"], J["l_ankle"]),
    (J["r_hip"], J["r_knee"]),
    (J["r_knee"], J["r_ankle"]),
    (J["nose"], J["l_eye"]),
    (J["nose"], J["r_eye"]),
    (J["l_eye"], J["l_ear"]),
    (J["r_eye"], J["r_ear"]),
)
# Left/right joint pairs (for flip correction and mirroring augmentation).
FLIP_PAIRS: tuple[tuple[int, int], ...] = tuple(
    (J[f"l_{n}"], J[f"r_{n}"])
    for n in ("eye", "ear", "shoulder", "elbow", "wrist", "hip", "knee", "ankle")
)
ACTIONS: tuple[str, ...] = ("still", "forward", "left", "right")
# Every value a per-frame label may take (TEAM.md LABELS): the actions, or ``ignore`` where none fits.
LABELS: tuple[str, ...] = (*ACTIONS, "ignore")


@dataclass(frozen=True, slots=True)
class SkeletonSequence:
    """A 3D skeleton over time in the CAVE frame.

    joints_m: (T, 17, 3) float, metres, NaN where a joint is unknown.
    fps: frames per second.
    labels: optional (T,) per-frame labels (strings from ``LABELS``).
    tags: optional (T,) free-text behaviour names (``march``, ``kneel``, ...; "" where none).
    contacts: optional (T, 2) bool, ground-truth foot contact [left, right].
    source: optional name of the generator or the clip the sequence came from.
    """

    joints_m: NDArray[np.float64]
    fps: float
    labels: tuple[str, ...] | None = None
    tags: tuple[str, ...] | None = None
    contacts: NDArray[np.bool_] | None = None
    source: str | None = None

    def __post_init__(self) -> None:
        j = np.asarray(self.joints_m)
        if j.ndim != 3 or j.shape[1:] != (NUM_JOINTS, 3):
            raise InputError(f"joints must have shape (T, 17, 3), got {j.shape}")
        if not np.isfinite(self.fps) or self.fps <= 0:
            raise InputError(f"fps must be a positive number, got {self.fps}")
        if self.labels is not None:
            if len(self.labels) != j.shape[0]:
                raise InputError(f"labels has {len(self.labels)} entries for {j.shape[0]} frames")
            unknown = sorted(set(self.labels) - set(LABELS))
            if unknown:
                raise InputError(f"unknown labels {unknown}; expected one of {list(LABELS)}")
        if self.tags is not None and len(self.tags) != j.shape[0]:
            raise InputError(f"tags has {len(self.tags)} entries for {j.shape[0]} frames")
        if self.contacts is not None:
            c = np.asarray(self.contacts)
            if c.shape != (j.shape[0], 2) or c.dtype != np.bool_:
                raise InputError(
                    f"contacts must be a bool array of shape ({j.shape[0]}, 2), got {c.dtype} {c.shape}"
                )

    def __len__(self) -> int:
        return int(self.joints_m.shape[0])


def save_npz(path: str | Path, seq: SkeletonSequence) -> None:
    """Write a skeleton sequence as the NPZ file of SPEC.md."""
    arrays: dict[str, NDArray] = {
        "joints": np.asarray(seq.joints_m, dtype=np.float32),
        "fps": np.asarray(seq.fps, dtype=np.float64),
    }
    if seq.labels is not None:
        arrays["labels"] = np.asarray(seq.labels, dtype=str)
    if seq.tags is not None:
        arrays["tags"] = np.asarray(seq.tags, dtype=str)
    if seq.contacts is not None:
        arrays["contacts"] = np.asarray(seq.contacts, dtype=bool)
    if seq.source is not None:
        arrays["source"] = np.asarray(seq.source, dtype=str)
    np.savez_compressed(Path(path), **arrays)  # type: ignore[arg-type]


def npz_read_error(path: Path, exc: Exception) -> InputError:
    """The one error for an NPZ that numpy could not read: an array of Python objects (labels from a
    pandas column) gets the way to save it instead, since reading it would unpickle (run code from
    the file)."""
    if isinstance(exc, ValueError) and "Object arrays" in str(exc):
        return InputError(
            f"{path}: an array holds Python objects, which cavewalk does not unpickle; save labels and "
            f"tags as strings (np.asarray(labels, dtype=str)) and joints and fps as numbers"
        )
    return InputError(f"{path}: not a readable NPZ skeleton file ({exc})")


def load_npz(path: str | Path) -> SkeletonSequence:
    """Read a skeleton-sequence NPZ; raises :class:`InputError` with a clear message."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p} is a folder, not an NPZ skeleton file")
    if not p.is_file():
        raise InputError(f"skeleton file not found: {p}")
    if not zipfile.is_zipfile(p):  # np.load would try a pickle: "contains pickled (object) data"
        raise InputError(f"{p}: not an NPZ file (expected a NumPy .npz archive of arrays)")
    try:
        with np.load(p, allow_pickle=False) as data:
            if "joints" not in data or "fps" not in data:
                raise InputError(f"{p}: an NPZ skeleton file needs the arrays 'joints' and 'fps'")
            joints = np.asarray(data["joints"], dtype=np.float64)
            fps = float(np.asarray(data["fps"]).reshape(()))
            labels = tuple(str(x) for x in data["labels"]) if "labels" in data else None
            tags = tuple(str(x) for x in data["tags"]) if "tags" in data else None
            contacts = np.asarray(data["contacts"]) if "contacts" in data else None
            source = str(np.asarray(data["source"]).reshape(())) if "source" in data else None
    except InputError:
        raise
    except Exception as exc:  # zipfile / pickle / shape errors from numpy
        raise npz_read_error(p, exc) from exc
    try:
        return SkeletonSequence(joints, fps, labels, tags, contacts, source)
    except InputError as exc:
        raise InputError(f"{p}: {exc}") from exc
