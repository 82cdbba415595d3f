"""Exporting a take (SPEC.md "Takes") for other tools: the bundle, TRC markers and a labels table.

- :func:`write_bundle` — the take's own files (SPEC skeleton NPZ, per-frame JSON Lines, labels,
  calibration, manifest, camera videos) plus the TRC and labels table below, as a zip or a folder;
- :func:`trc_text` — one person's joints as a TRC marker file, the format of Pose2Sim and OpenSim:
  metres, Y-up (Pose2Sim's ``zup2yup``: X = CAVE Y (front), Y = CAVE Z (up), Z = CAVE X (right)),
  resampled to a uniform rate (the take's frames come at the capture's pace, not a fixed one);
- :func:`labels_table` — one row per frame and labelled person (take, participant, time, label,
  tag, the recogniser's output), a plain CSV for R and SPSS.

Every export first checks the take (:func:`verified_take`): a take still recording, or whose
files are missing or do not match their sha256, is refused with one message naming them, and
nothing is written. Outputs are written beside their destination and renamed into place, so a
failed export leaves no partial file.
"""

from __future__ import annotations

import csv
import io
import math
import os
import shutil
import zipfile
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import DataError, InputError
from pipeline.skeleton import NUM_JOINTS
from pipeline.takes.files import (
    FRAMES,
    LABELS,
    MANIFEST,
    SKELETONS,
    check_files,
    load_manifest,
    read_frames,
    read_spans,
    skeleton_arrays,
)
from pipeline.takes.protocol import LabelSpan

#: The COCO joints under the names Pose2Sim gives them (its ``skeletons.py``), in COCO order.
TRC_MARKERS: tuple[str, ...] = (
    "Nose", "LEye", "REye", "LEar", "REar", "LShoulder", "RShoulder", "LElbow", "RElbow",
    "LWrist", "RWrist", "LHip", "RHip", "LKnee", "RKnee", "LAnkle", "RAnkle",
)
FORMATS = ("zip", "folder", "trc", "labels")
LABEL_TABLE_COLUMNS = (
    "take", "participant_code", "user_id", "frame", "t_s", "label", "tag", "label_source",
    "navigator", "predicted", "predicted_confidence",
)
_STORED = (".mp4", ".npz")  # already compressed: stored as they are in the zip


# ----------------------------------------------------------------------------------- checking
def verified_take(folder: Path) -> dict[str, Any]:
    """The take's manifest, once it is known to be finished and whole; else one clear error."""
    folder = Path(folder)
    manifest = load_manifest(folder)
    name = manifest.get("id", folder.name)
    if manifest.get("status") == "recording":
        raise InputError(f"take {name} is still recording; export it once it has ended")
    problems = check_files(folder, manifest)
    listed = manifest.get("files") or {}
    problems += [f"{f} is missing" for f in (FRAMES, SKELETONS) if f not in listed and
                 f"{f} is missing" not in problems]
    if problems:
        raise DataError(f"take {name} ({folder}) is damaged: {'; '.join(problems)}; nothing was exported")
    return manifest


def users_of(arrays: dict[str, NDArray[Any]]) -> list[int]:
    return sorted(int(k.removeprefix("joints_")) for k in arrays if k.startswith("joints_"))


def _pick_user(arrays: dict[str, NDArray[Any]], user_id: int | None, name: str) -> int:
    users = users_of(arrays)
    if user_id is None:
        if "user_id" not in arrays:
            raise InputError(f"take {name} has no participant (nobody was tracked); nothing to export")
        return int(arrays["user_id"])
    if user_id not in users:
        raise InputError(f"take {name} has no user {user_id}; it has {users or 'nobody'}")
    return user_id


# ---------------------------------------------------------------------------------------- TRC
def resample(joints: NDArray[np.float32], t: NDArray[np.float64], rate_hz: float
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``joints`` (T, J, 3) at times ``t`` on a uniform grid of ``rate_hz``: linear between the two
    frames around each grid time, NaN where either is unknown. Returns (times, joints)."""
    finite = np.isfinite(t)
    t, joints = t[finite], joints[finite]
    if len(t) == 0:
        return np.zeros(0), np.zeros((0, *joints.shape[1:]))
    # t is sorted: the span is >= 0; the slack is for float rounding only (a span a hair under a
    # whole number of samples), so no grid time lies past the last frame by more than rounding
    n = int(float(t[-1] - t[0]) * rate_hz + 1e-9) + 1
    grid = t[0] + np.arange(n) / rate_hz
    i = np.clip(np.searchsorted(t, grid, side="right") - 1, 0, len(t) - 1)
    j = np.minimum(i + 1, len(t) - 1)
    span = t[j] - t[i]
    w = np.where(span > 0, (grid - t[i]) / np.where(span > 0, span, 1.0), 0.0)
    w = np.clip(w, 0.0, 1.0)[:, None, None]
    a, b = joints[i].astype(np.float64), joints[j].astype(np.float64)
    out = a * (1 - w) + b * w
    exact = (w == 0.0)  # on a frame: its own value (the next frame may be unknown)
    out = np.where(exact, a, out)
    return grid, out


def trc_text(joints: NDArray[Any], t: NDArray[Any], file_name: str, rate_hz: float) -> str:
    """A TRC file (Pose2Sim's ``make_trc`` layout) of joints (T, 17, 3) in the CAVE frame (metres,
    Z-up) at times ``t`` (seconds), resampled to ``rate_hz``; unknown coordinates are empty."""
    joints = np.asarray(joints)
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise InputError(f"TRC export needs joints of shape (T, {NUM_JOINTS}, 3), got {joints.shape}")
    if not (math.isfinite(rate_hz) and 1 <= rate_hz <= 1000):
        raise InputError(f"the TRC rate must be in [1, 1000] Hz, got {rate_hz}")
    grid, xyz = resample(joints, np.asarray(t, dtype=np.float64), rate_hz)
    yup = xyz[..., [1, 2, 0]]  # Z-up -> Y-up as Pose2Sim's zup2yup: (X, Y, Z) = (Y, Z, X)
    rate = f"{rate_hz:g}"
    n, m = len(grid), len(TRC_MARKERS)
    lines = [
        f"PathFileType\t4\t(X/Y/Z)\t{file_name}",
        "DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames",
        f"{rate}\t{rate}\t{n}\t{m}\tm\t{rate}\t1\t{n}",
        "Frame#\tTime\t" + "\t\t\t".join(TRC_MARKERS) + "\t\t\t",
        "\t\t" + "\t".join(f"X{k + 1}\tY{k + 1}\tZ{k + 1}" for k in range(m)) + "\t",
    ]
    t0 = grid[0] if n else 0.0
    for k in range(n):
        vals = "\t".join("" if not math.isfinite(v) else f"{v:.5f}" for v in yup[k].reshape(-1))
        lines.append(f"{k + 1}\t{grid[k] - t0:.5f}\t{vals}")
    return "\n".join(lines) + "\n"


def take_trc(folder: Path, user_id: int | None = None, rate_hz: float | None = None) -> tuple[str, str]:
    """(file name, TRC text) of one person of a take (default: its participant)."""
    manifest = verified_take(folder)
    name = str(manifest.get("id", Path(folder).name))
    arrays = _load_arrays(Path(folder))
    uid = _pick_user(arrays, user_id, name)
    rate = rate_hz if rate_hz is not None else float(round(float(arrays["fps"]))) or 30.0
    file_name = f"{name}_P{uid}.trc"
    return file_name, trc_text(arrays[f"joints_{uid}"], arrays["t"], file_name, rate)


def _load_arrays(folder: Path) -> dict[str, NDArray[Any]]:
    try:
        with np.load(folder / SKELETONS, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files}
    except (OSError, ValueError, zipfile.BadZipFile) as exc:
        raise DataError(f"{folder / SKELETONS}: cannot read the skeletons: {exc}") from None


# ------------------------------------------------------------------------------ labels table
def _span_at(spans: list[LabelSpan], t: float, user: int, navigator: int) -> LabelSpan | None:
    found = None
    for s in spans:  # the last span that covers it wins (as frame_labels)
        if s.t_start <= t < s.t_end and (s.user_id == user or (s.user_id is None and navigator == user)):
            found = s
    return found


def labels_table(folder: Path) -> bytes:
    """The per-frame labels of a take as CSV (:data:`LABEL_TABLE_COLUMNS`), one row per frame and
    labelled person; ``ignore`` rows are kept (filter them in R/SPSS). Unknown values are empty."""
    manifest = verified_take(folder)
    name = str(manifest.get("id", Path(folder).name))
    spans = read_spans(Path(folder) / LABELS)
    if not spans:
        raise InputError(f"take {name} has no labels (recorded without a protocol); label it first")
    frames, _ = read_frames(Path(folder) / FRAMES)
    arrays = skeleton_arrays(frames, spans)
    users = sorted(int(k.removeprefix("labels_")) for k in arrays if k.startswith("labels_"))
    code = manifest.get("participant_code") or ""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(LABEL_TABLE_COLUMNS)
    for f in frames:
        t = f.get("t")
        if t is None:
            continue
        nav = -1 if f.get("navigator") is None else int(f["navigator"])
        action = f.get("action") or {}
        for uid in users:
            span = _span_at(spans, float(t), uid, nav)
            is_nav = nav == uid
            conf = action.get("confidence")
            w.writerow([
                name, code, uid, f.get("frame", ""), f"{float(t):.4f}",
                span.label if span else "ignore", span.tag if span else "", span.source if span else "",
                int(is_nav), (action.get("label") or "") if is_nav else "",
                f"{float(conf):.4f}" if is_nav and isinstance(conf, int | float) else "",
            ])
    return buf.getvalue().encode("utf-8")


# ------------------------------------------------------------------------------------ bundle
def _tmp_beside(path: Path) -> Path:
    return path.with_name(f".{path.name}.part-{os.getpid()}")


def _extras(folder: Path, manifest: dict[str, Any]) -> dict[str, bytes]:
    """The derived files of the bundle: a TRC per tracked person, the labels table if labelled."""
    out: dict[str, bytes] = {}
    arrays = _load_arrays(folder)
    name = str(manifest.get("id", folder.name))
    rate = float(round(float(arrays["fps"]))) or 30.0
    for uid in users_of(arrays):
        file_name = f"{name}_P{uid}.trc"
        out[f"trc/{file_name}"] = trc_text(arrays[f"joints_{uid}"], arrays["t"], file_name, rate).encode()
    if read_spans(folder / LABELS):
        out["labels_frames.csv"] = labels_table(folder)
    return out


def write_bundle(folder: Path, out: Path, *, as_zip: bool = True) -> list[str]:
    """The take's files (every one its manifest lists, and the manifest) plus ``trc/*.trc`` and
    ``labels_frames.csv`` into a zip (members under the take's id) or a new folder. Returns the
    member names. ``out`` must not exist."""
    folder, out = Path(folder), Path(out)
    manifest = verified_take(folder)
    if out.exists():
        raise InputError(f"{out} already exists; an export goes to a new file or folder")
    if not out.parent.is_dir():
        raise InputError(f"{out.parent} is not a folder")
    names = [*sorted(manifest.get("files") or {}), MANIFEST]
    extras = _extras(folder, manifest)
    tmp = _tmp_beside(out)
    try:
        if as_zip:
            root = str(manifest.get("id", folder.name))
            with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED, allowZip64=True) as zf:
                for n in names:
                    kind = zipfile.ZIP_STORED if n.endswith(_STORED) else zipfile.ZIP_DEFLATED
                    zf.write(folder / n, f"{root}/{n}", compress_type=kind)
                for n, data in extras.items():
                    zf.writestr(f"{root}/{n}", data)
        else:
            tmp.mkdir()
            for n in names:
                (tmp / n).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(folder / n, tmp / n)
            for n, data in extras.items():
                (tmp / n).parent.mkdir(parents=True, exist_ok=True)
                (tmp / n).write_bytes(data)
        os.replace(tmp, out)
    except BaseException:
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
        else:
            tmp.unlink(missing_ok=True)
        raise
    return [*names, *extras]


def write_export(folder: Path, out: Path, fmt: str, user_id: int | None = None) -> list[str]:
    """Export a take as ``fmt`` (:data:`FORMATS`) into ``out`` (a new file, or folder for
    ``folder``). Returns what was written."""
    if fmt not in FORMATS:
        raise InputError(f"export format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    out = Path(out)
    if fmt in ("zip", "folder"):
        return write_bundle(folder, out, as_zip=fmt == "zip")
    if out.exists():
        raise InputError(f"{out} already exists; an export goes to a new file")
    if not out.parent.is_dir():
        raise InputError(f"{out.parent} is not a folder")
    data = take_trc(folder, user_id)[1].encode() if fmt == "trc" else labels_table(folder)
    tmp = _tmp_beside(out)
    try:
        tmp.write_bytes(data)
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return [out.name]


def export_summary(folder: Path) -> dict[str, Any]:
    """What a take can be exported as (for the API): its users and whether it has labels."""
    manifest = verified_take(folder)
    arrays = _load_arrays(Path(folder))
    return {"id": manifest.get("id"), "users": users_of(arrays),
            "participant_user_id": int(arrays["user_id"]) if "user_id" in arrays else None,
            "labelled": bool(read_spans(Path(folder) / LABELS)), "formats": list(FORMATS),
            "videos": sorted(n for n in (manifest.get("files") or {}) if n.startswith("videos/"))}
