"""Labelled skeleton sequences (the LABELS convention every source follows) and their loader.

A labelled sequence is a SPEC skeleton NPZ with, besides ``joints`` (T, 17, 3) metres and
``fps``, ``labels`` (T,) strings from ``still | forward | left | right | ignore``, optional
``tags`` (T,) free-text behaviour names, optional ``contacts`` (T, 2) bool ground-truth foot
contact [left, right] and an optional scalar ``source``. Unknown arrays are ignored.

:func:`load_labelled` checks everything and raises :class:`InputError` with one clear message
(no labels, a wrong shape, an unknown label, a file that is not an NPZ).
"""

from __future__ import annotations

import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.skeleton import ACTIONS, NUM_JOINTS, npz_read_error

IGNORE = "ignore"
LABEL_NAMES: tuple[str, ...] = (*ACTIONS, IGNORE)
IGNORE_INDEX = -1


@dataclass(frozen=True, slots=True)
class LabelledSequence:
    """One labelled skeleton sequence.

    joints_m: (T, 17, 3) float64 metres, CAVE frame, NaN unknown.
    fps: frames per second.
    labels: (T,) int64 class indices into ACTIONS, IGNORE_INDEX (-1) for ``ignore``.
    tags: (T,) str behaviour names ("" where nothing special).
    contacts: (T, 2) bool ground-truth foot contact [left, right], or None.
    source: the generator or clip ("" when the file does not say).
    name: what the sequence is called in reports (the file name).
    """

    joints_m: NDArray[np.float64]
    fps: float
    labels: NDArray[np.int64]
    tags: NDArray[np.str_]
    contacts: NDArray[np.bool_] | None = None
    source: str = ""
    name: str = ""

    def __post_init__(self) -> None:
        j = np.asarray(self.joints_m)
        if j.ndim != 3 or j.shape[1:] != (NUM_JOINTS, 3):
            raise ValueError(f"joints_m must have shape (T, {NUM_JOINTS}, 3), got {j.shape}")
        t = j.shape[0]
        if not np.isfinite(self.fps) or self.fps <= 0:
            raise ValueError(f"fps must be a positive number, got {self.fps}")
        if np.asarray(self.labels).shape != (t,):
            raise ValueError(f"labels must have shape ({t},), got {np.asarray(self.labels).shape}")
        lab = np.asarray(self.labels)
        if lab.size and (lab.min() < IGNORE_INDEX or lab.max() >= len(ACTIONS)):
            raise ValueError(f"labels must be in [{IGNORE_INDEX}, {len(ACTIONS) - 1}]")
        if np.asarray(self.tags).shape != (t,):
            raise ValueError(f"tags must have shape ({t},), got {np.asarray(self.tags).shape}")
        if self.contacts is not None and np.asarray(self.contacts).shape != (t, 2):
            raise ValueError(f"contacts must have shape ({t}, 2), got {np.asarray(self.contacts).shape}")

    def __len__(self) -> int:
        return int(self.joints_m.shape[0])

    @property
    def label_names(self) -> list[str]:
        return [LABEL_NAMES[i] for i in self.labels]  # -1 -> "ignore" (the last name)


def encode_labels(labels: Sequence[str] | NDArray[np.str_], where: str = "labels") -> NDArray[np.int64]:
    """Label strings -> indices (ignore = -1); :class:`InputError` naming any unknown label."""
    arr = np.asarray(labels).astype(str)
    unknown = sorted(set(np.unique(arr).tolist()) - set(LABEL_NAMES))
    if unknown:
        raise InputError(
            f"{where}: unknown label(s) {', '.join(map(repr, unknown[:5]))}; "
            f"labels must be one of {', '.join(LABEL_NAMES)}"
        )
    lookup = {name: i for i, name in enumerate(ACTIONS)} | {IGNORE: IGNORE_INDEX}
    return np.asarray([lookup[x] for x in arr.tolist()], dtype=np.int64)


def load_labelled(path: str | Path) -> LabelledSequence:
    """Read and check a labelled skeleton NPZ; :class:`InputError` with one clear message."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{p} is a folder, not an NPZ skeleton file (give its files: {p / '*.npz'})")
    if not p.is_file():
        raise InputError(f"skeleton file not found: {p}")
    if not zipfile.is_zipfile(p):
        raise InputError(f"{p}: not an NPZ file (expected a NumPy .npz archive of arrays)")
    try:
        with np.load(p, allow_pickle=False) as z:
            keys = set(z.files)
            for key in ("joints", "fps"):
                if key not in keys:
                    raise InputError(f"{p}: an NPZ skeleton file needs the array {key!r}")
            if "labels" not in keys:
                raise InputError(f"{p}: no 'labels' array: evaluation needs labelled sequences")
            joints = np.asarray(z["joints"], dtype=np.float64)
            fps_arr = np.asarray(z["fps"])
            labels_raw = np.asarray(z["labels"])
            tags_raw = np.asarray(z["tags"]) if "tags" in keys else None
            contacts_raw = np.asarray(z["contacts"]) if "contacts" in keys else None
            source_raw = np.asarray(z["source"]) if "source" in keys else None
    except InputError:
        raise
    except Exception as exc:  # zip member / object-array / dtype errors from numpy
        raise npz_read_error(p, exc) from exc
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise InputError(f"{p}: joints must have shape (T, {NUM_JOINTS}, 3), got {joints.shape}")
    t = joints.shape[0]
    if t == 0:
        raise InputError(f"{p}: the sequence has no frames")
    if fps_arr.size != 1 or fps_arr.dtype.kind not in "iuf":
        raise InputError(f"{p}: fps must be one number, got an array of shape {fps_arr.shape}")
    fps = float(fps_arr.reshape(()))
    if not np.isfinite(fps) or fps <= 0:
        raise InputError(f"{p}: fps must be a positive number, got {fps}")
    if labels_raw.shape != (t,) or labels_raw.dtype.kind not in "US":
        raise InputError(
            f"{p}: labels must be ({t},) strings (one per frame), got {labels_raw.dtype} {labels_raw.shape}"
        )
    labels = encode_labels(labels_raw, where=str(p))
    if tags_raw is None:
        tags = np.full(t, "", dtype="<U1")
    elif tags_raw.shape != (t,) or tags_raw.dtype.kind not in "US":
        raise InputError(f"{p}: tags must be ({t},) strings, got {tags_raw.dtype} {tags_raw.shape}")
    else:
        tags = tags_raw.astype(str)
    contacts = None
    if contacts_raw is not None:
        if contacts_raw.shape != (t, 2) or contacts_raw.dtype.kind not in "biu":
            raise InputError(
                f"{p}: contacts must be ({t}, 2) booleans [left, right], got "
                f"{contacts_raw.dtype} {contacts_raw.shape}"
            )
        contacts = contacts_raw.astype(bool)
    source = ""
    if source_raw is not None and source_raw.size == 1 and source_raw.dtype.kind in "US":
        source = str(source_raw.reshape(()))
    joints = np.where(np.isfinite(joints), joints, np.nan)  # inf is unknown, like NaN
    return LabelledSequence(joints, fps, labels, tags, contacts, source or p.stem, p.name)


def save_labelled(path: str | Path, seq: LabelledSequence) -> None:
    """Write a labelled sequence as a SPEC skeleton NPZ (labels as strings)."""
    arrays: dict[str, NDArray] = {
        "joints": np.asarray(seq.joints_m, dtype=np.float32),
        "fps": np.asarray(seq.fps, dtype=np.float64),
        "labels": np.asarray(seq.label_names, dtype=str),
        "tags": np.asarray(seq.tags, dtype=str),
    }
    if seq.contacts is not None:
        arrays["contacts"] = np.asarray(seq.contacts, dtype=bool)
    if seq.source:
        arrays["source"] = np.asarray(seq.source)
    np.savez_compressed(Path(path), **arrays)  # type: ignore[arg-type]
