"""The files of a take folder (SPEC.md "Takes"): reading, checking, finishing and recovering.

A take is written as it goes: ``take.json`` (``complete`` false) and ``calibration.json`` at the
start, ``frames.jsonl`` line by line (on disk at least every second), ``labels.csv`` whenever the
labels change. :func:`finish_take` builds ``skeletons.npz`` from the frames, lists every file with
its sha256 and sets ``complete``; :func:`recover_take` does the same for a take a crash left
behind (``complete`` stays false, ``status`` is ``incomplete``), dropping a last line the crash cut.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
import math
import os
from collections import Counter
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import DataError, InputError
from pipeline.skeleton import NUM_JOINTS
from pipeline.takes.protocol import LabelSpan

MANIFEST = "take.json"
FRAMES = "frames.jsonl"
SKELETONS = "skeletons.npz"
LABELS = "labels.csv"
CALIBRATION = "calibration.json"
LABEL_COLUMNS = ("t_start", "t_end", "label", "user_id", "source", "tag")


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename (a crash leaves old or new)."""
    tmp = path.with_name(path.name + ".tmp")
    with tmp.open("wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def write_json(path: Path, obj: Any) -> None:
    write_atomic(path, (json.dumps(obj, indent=1, allow_nan=False) + "\n").encode("utf-8"))


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


# ------------------------------------------------------------------------------------ manifest
def load_manifest(folder: Path) -> dict[str, Any]:
    path = Path(folder) / MANIFEST
    if not Path(folder).is_dir():
        raise InputError(f"take folder not found: {folder}")
    if not path.is_file():
        raise InputError(f"{folder}: not a take folder (no {MANIFEST})")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path}: cannot read the take's manifest: {exc}") from None
    if not isinstance(data, dict) or "id" not in data:
        raise InputError(f"{path}: a take manifest is a JSON object with an 'id'")
    return data


def check_files(folder: Path, manifest: dict[str, Any] | None = None) -> list[str]:
    """What is wrong with the take's files (missing, changed); empty when all is well."""
    folder = Path(folder)
    manifest = manifest if manifest is not None else load_manifest(folder)
    problems = []
    files = manifest.get("files") or {}
    for name, info in sorted(files.items()):
        path = folder / name
        if not path.is_file():
            problems.append(f"{name} is missing")
        elif isinstance(info, dict) and info.get("sha256") and sha256_of(path) != info["sha256"]:
            problems.append(f"{name} does not match its sha256")
    if not files and not (folder / FRAMES).is_file():
        problems.append(f"{FRAMES} is missing")
    return problems


# -------------------------------------------------------------------------------------- frames
def read_frames(path: Path) -> tuple[list[dict[str, Any]], bool]:
    """The frames of a ``frames.jsonl`` and whether its last line was cut (and dropped)."""
    if not path.is_file():
        raise InputError(f"{path.parent}: {path.name} is missing")
    frames: list[dict[str, Any]] = []
    cut = False
    with path.open("rb") as f:
        lines = f.read().split(b"\n")
    last = max((i for i, r in enumerate(lines) if r.strip()), default=-1)
    for i, raw in enumerate(lines):
        if not raw.strip():
            continue
        try:
            obj = json.loads(raw)
            if not isinstance(obj, dict) or "t" not in obj:
                raise ValueError("not a frame object")
        except (ValueError, UnicodeDecodeError) as exc:
            if i == last:
                cut = True  # the crash cut the line being written
                continue
            raise InputError(f"{path}: line {i + 1} is not a per-frame result: {exc}") from None
        frames.append(obj)
    return frames, cut


def read_spans(path: Path) -> list[LabelSpan]:
    if not path.is_file():
        return []
    out = []
    with path.open(newline="", encoding="utf-8") as f:
        for i, row in enumerate(csv.DictReader(f)):
            try:
                uid = row.get("user_id") or ""
                out.append(
                    LabelSpan(
                        float(row["t_start"]),
                        float(row["t_end"]),
                        row["label"],
                        int(uid) if uid.strip() else None,
                        row.get("source") or "protocol",
                        row.get("tag") or "",
                    )
                )
            except (KeyError, TypeError, ValueError) as exc:
                raise InputError(f"{path}: row {i + 2}: {exc}") from None
    return out


def spans_csv(spans: list[LabelSpan]) -> bytes:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(LABEL_COLUMNS)
    for s in spans:
        w.writerow(
            [
                f"{s.t_start:.3f}",
                f"{s.t_end:.3f}",
                s.label,
                "" if s.user_id is None else s.user_id,
                s.source,
                s.tag,
            ]
        )
    return buf.getvalue().encode("utf-8")


def write_spans(folder: Path, spans: list[LabelSpan]) -> None:
    write_atomic(Path(folder) / LABELS, spans_csv(spans))


# ---------------------------------------------------------------------------------- skeletons
def participant_of(frames: list[dict[str, Any]]) -> int | None:
    """The user who was the navigator in most frames (the participant the protocol prompts)."""
    counts = Counter(int(f["navigator"]) for f in frames if f.get("navigator") is not None)
    return counts.most_common(1)[0][0] if counts else None


def skeleton_arrays(frames: list[dict[str, Any]], spans: list[LabelSpan]) -> dict[str, NDArray[Any]]:
    """The arrays of ``skeletons.npz``: ``t``, ``fps``, ``navigator`` and per user ``joints_<id>``
    (and ``labels_<id>`` where spans give them), plus ``joints``/``labels`` of the participant so the
    file is also a plain SPEC skeleton NPZ."""
    T = len(frames)
    t = np.array([float(f["t"]) if f.get("t") is not None else math.nan for f in frames], dtype=np.float64)
    nav = np.array(
        [-1 if f.get("navigator") is None else int(f["navigator"]) for f in frames], dtype=np.int64
    )
    users: dict[int, NDArray[np.float32]] = {}
    for i, f in enumerate(frames):
        for p in f.get("people3d") or ():
            uid = int(p["user_id"])
            arr = users.get(uid)
            if arr is None:
                arr = users[uid] = np.full((T, NUM_JOINTS, 3), np.nan, dtype=np.float32)
            for j, xyz in enumerate((p.get("joints") or ())[:NUM_JOINTS]):
                if xyz is not None:
                    arr[i, j] = [np.nan if v is None else v for v in xyz]
    fps = 0.0
    if T >= 2 and np.isfinite(t[[0, -1]]).all() and t[-1] > t[0]:
        fps = float((T - 1) / (t[-1] - t[0]))
    out: dict[str, NDArray[Any]] = {"t": t, "fps": np.asarray(fps or 30.0), "navigator": nav}
    for uid, arr in sorted(users.items()):
        out[f"joints_{uid}"] = arr
    labelled = {s.user_id for s in spans}
    label_users = {u for u in labelled if u is not None}
    if None in labelled:
        label_users |= {int(u) for u in set(nav.tolist()) if u >= 0}
    for uid in sorted(label_users):
        labels = np.full(T, "ignore", dtype="<U8")
        for i in range(T):
            for s in spans:
                if s.t_start <= t[i] < s.t_end and (
                    s.user_id == uid or (s.user_id is None and nav[i] == uid)
                ):
                    labels[i] = s.label
        out[f"labels_{uid}"] = labels
    main = participant_of(frames)
    if main is not None and f"joints_{main}" in out:
        out["joints"] = out[f"joints_{main}"]
        if f"labels_{main}" in out:
            out["labels"] = out[f"labels_{main}"]
        out["user_id"] = np.asarray(main)
    return out


def write_skeletons(folder: Path, frames: list[dict[str, Any]], spans: list[LabelSpan]) -> None:
    buf = io.BytesIO()
    np.savez_compressed(buf, **skeleton_arrays(frames, spans))  # type: ignore[arg-type]
    write_atomic(Path(folder) / SKELETONS, buf.getvalue())


# ------------------------------------------------------------------------------- finish/recover
def file_table(folder: Path) -> dict[str, dict[str, Any]]:
    """Every file of the take but the manifest: name -> bytes and sha256."""
    folder = Path(folder)
    out = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file() and p.name != MANIFEST and not p.name.endswith(".tmp"):
            out[p.relative_to(folder).as_posix()] = {"bytes": p.stat().st_size, "sha256": sha256_of(p)}
    return out


def finish_take(
    folder: Path, *, complete: bool, end_unix: float | None = None, manifest: dict[str, Any] | None = None
) -> dict[str, Any]:
    """Build ``skeletons.npz``, list the files with their checksums and write the final manifest."""
    folder = Path(folder)
    manifest = dict(manifest if manifest is not None else load_manifest(folder))
    frames, cut = read_frames(folder / FRAMES)
    spans = read_spans(folder / LABELS)
    ts = [float(f["t"]) for f in frames if f.get("t") is not None]
    duration = max(ts) if ts else 0.0
    if spans:  # the protocol's spans end where the take ended (it may stop early)
        end = round(duration + (duration / (len(ts) - 1) if len(ts) > 1 else 0.05), 3)
        clipped = [replace(sp, t_end=min(sp.t_end, end)) for sp in spans if sp.t_start < end]
        if clipped != spans:
            spans = clipped
            write_spans(folder, spans)
    write_skeletons(folder, frames, spans)
    manifest.update(
        {
            "complete": bool(complete),
            "status": "complete" if complete else "incomplete",
            "frames": len(frames),
            "duration_s": round(duration, 3),
            "end_unix": end_unix if end_unix is not None else (manifest.get("start_unix", 0.0) + duration),
            "participant_user_id": participant_of(frames),
            "cut_last_line": cut,
            "files": file_table(folder),
        }
    )
    write_json(folder / MANIFEST, manifest)
    return manifest


def recover_take(folder: Path) -> dict[str, Any]:
    """A take a crash left unfinished: everything up to its last whole frame, marked ``incomplete``."""
    folder = Path(folder)
    manifest = load_manifest(folder)
    if manifest.get("complete"):
        return manifest
    if not (folder / FRAMES).is_file():
        (folder / FRAMES).touch()
    return finish_take(folder, complete=False, manifest=manifest)


def relabel_take(folder: Path, spans: list[LabelSpan]) -> dict[str, Any]:
    """Replace a finished take's labels: ``labels.csv``, the labels in ``skeletons.npz``, the checksums.

    Everything is checked and built in memory first; a bad take changes nothing.
    """
    folder = Path(folder)
    manifest = load_manifest(folder)
    if manifest.get("status") == "recording":
        raise InputError(f"take {manifest.get('id')} is still recording")
    rewritten = {f"{LABELS} is missing", f"{LABELS} does not match its sha256",
                 f"{SKELETONS} is missing", f"{SKELETONS} does not match its sha256"}
    problems = [p for p in check_files(folder, manifest) if p not in rewritten]  # those two are rebuilt
    if problems:
        raise DataError(f"take {manifest.get('id')} ({folder}) is damaged: {'; '.join(problems)}; "
                        "its labels were not changed")
    frames, _cut = read_frames(folder / FRAMES)
    buf = io.BytesIO()
    np.savez_compressed(buf, **skeleton_arrays(frames, spans))  # type: ignore[arg-type]
    labels_bytes = spans_csv(spans)
    write_atomic(folder / LABELS, labels_bytes)
    write_atomic(folder / SKELETONS, buf.getvalue())
    manifest["files"] = file_table(folder)
    manifest["labelled_by"] = "operator"
    write_json(folder / MANIFEST, manifest)
    return manifest
