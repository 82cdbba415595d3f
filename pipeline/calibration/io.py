"""Calibration files: the JSON of SPEC.md, Pose2Sim's ``Calib*.toml`` and Qualisys ``*.qca.txt``.

Every reader returns :class:`pipeline.camera.Camera` objects in the OpenCV model of
SPEC.md (world-to-camera R, t in metres); :func:`load_calibration` picks the reader
from the file's name and content.
"""

from __future__ import annotations

import json
import logging
import math
import re
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera
from pipeline.errors import InputError, read_user_text

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]

#: Qualisys stores image positions in sub-pixel sensor units: 64 per pixel (Pose2Sim's calib_qca_fun).
QUALISYS_SUBPIXELS = 64.0

# Qualisys cameras look along their -z axis with +y up; OpenCV along +z with +y down.
_FLIP_YZ = np.diag([1.0, -1.0, -1.0])


def _natural_key(name: str) -> list[int | str]:
    return [int(part) if part.isdigit() else part.lower() for part in re.split(r"(\d+)", name)]


def _check_names(cameras: Sequence[Camera], source: Path) -> list[Camera]:
    if not cameras:
        raise InputError(f"calibration {source} holds no cameras")
    names = [c.name for c in cameras]
    if len(set(names)) != len(names):
        raise InputError(f"calibration {source}: camera names must be unique, got {names}")
    return list(cameras)


# ---------------------------------------------------------------- SPEC JSON


def calibration_to_dict(cameras: Sequence[Camera]) -> dict[str, Any]:
    """The calibration JSON object of SPEC.md."""
    return {"cameras": [c.to_dict() for c in cameras]}


def cameras_from_dict(data: object, source: Path | str = "calibration") -> list[Camera]:
    """Parse the calibration JSON object of SPEC.md."""
    if not isinstance(data, dict) or not isinstance(data.get("cameras"), list):
        raise InputError(f"{source}: expected a JSON object with a 'cameras' list")
    try:
        cameras = [Camera.from_dict(item) for item in data["cameras"]]
    except (TypeError, ValueError, KeyError) as exc:
        raise InputError(f"malformed calibration {source}: {exc}") from exc
    return _check_names(cameras, Path(str(source)))


def save_calibration(path: Path | str, cameras: Sequence[Camera]) -> None:
    """Write the calibration JSON of SPEC.md."""
    _check_names(cameras, Path(path))
    Path(path).write_text(json.dumps(calibration_to_dict(cameras), indent=1) + "\n", encoding="utf-8")


def _read_json(path: Path, text: str) -> list[Camera]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"calibration {path} is not valid JSON: {exc}") from exc
    return cameras_from_dict(data, path)


# ---------------------------------------------------------------- Pose2Sim TOML


def _read_toml(path: Path, text: str) -> list[Camera]:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"calibration {path} is not valid TOML: {exc}") from exc
    cameras = []
    for key, section in data.items():
        if key == "metadata" or not isinstance(section, dict):
            continue
        required = ("size", "matrix", "distortions", "rotation", "translation")
        missing = [k for k in required if k not in section]
        if missing:
            raise InputError(f"calibration {path}: camera [{key}] is missing {', '.join(missing)}")
        if section.get("fisheye", False):
            raise InputError(f"calibration {path}: camera [{key}] uses the fisheye model (not supported)")
        try:
            rvec = np.asarray(section["rotation"], dtype=np.float64).reshape(3)
            size = [float(v) for v in section["size"]]
            cameras.append(
                Camera(
                    name=str(section.get("name", key)),
                    image_size=(round(size[0]), round(size[1])),
                    K=np.asarray(section["matrix"], dtype=np.float64),
                    dist=np.asarray(section["distortions"], dtype=np.float64),
                    R=cv2.Rodrigues(rvec)[0],
                    t=np.asarray(section["translation"], dtype=np.float64),
                )
            )
        except (TypeError, ValueError, IndexError) as exc:
            raise InputError(f"calibration {path}: camera [{key}] is malformed: {exc}") from exc
    return _check_names(cameras, path)


def _toml_value(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[ " + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else "nan"
    return str(value)


def save_pose2sim_toml(path: Path | str, cameras: Sequence[Camera]) -> None:
    """Write Pose2Sim's calibration TOML (also read by Anipose-style tools); metres, Rodrigues vectors."""
    _check_names(cameras, Path(path))
    lines: list[str] = []
    for cam in cameras:
        section = re.sub(r"[^A-Za-z0-9_-]", "_", cam.name)
        lines += [
            f"[{section}]",
            f"name = {_toml_value(cam.name)}",
            f"size = {_toml_value([float(v) for v in cam.image_size])}",
            f"matrix = {_toml_value(cam.K.tolist())}",
            f"distortions = {_toml_value(cam.dist[:4].tolist())}",
            f"rotation = {_toml_value(cam.rvec.tolist())}",
            f"translation = {_toml_value(cam.t.tolist())}",
            "fisheye = false",
            "",
        ]
    errors = [c.rms_px for c in cameras if not math.isnan(c.rms_px)]
    lines += ["[metadata]", "adjusted = false", f"error = {float(np.mean(errors)) if errors else 0.0!r}", ""]
    Path(path).write_text("\n".join(lines), encoding="utf-8")


# ---------------------------------------------------------------- Qualisys QCA


def _attr(elem: ET.Element, name: str, path: Path, camera: str) -> float:
    value = elem.get(name)
    if value is None:
        raise InputError(f"calibration {path}: camera {camera} <{elem.tag}> lacks {name!r}")
    try:
        return float(value)
    except ValueError as exc:
        raise InputError(f"calibration {path}: camera {camera} {name}={value!r} is not a number") from exc


def _qca_camera(cam: ET.Element, path: Path, binning: float) -> Camera:
    name = cam.get("serial") or "?"
    fov, intr, tr = cam.find("fov_video"), cam.find("intrinsic"), cam.find("transform")
    if fov is None or intr is None or tr is None:
        raise InputError(f"calibration {path}: camera {name} lacks fov_video, intrinsic or transform")
    left, top = _attr(fov, "left", path, name), _attr(fov, "top", path, name)
    width = (_attr(fov, "right", path, name) - left + 1) / binning
    height = (_attr(fov, "bottom", path, name) - top + 1) / binning
    scale = QUALISYS_SUBPIXELS * binning
    fu, fv = _attr(intr, "focalLengthU", path, name) / scale, _attr(intr, "focalLengthV", path, name) / scale
    cu = _attr(intr, "centerPointU", path, name) / scale - left
    cv = _attr(intr, "centerPointV", path, name) / scale - top
    # Distortion coefficients scaled as Pose2Sim's calib_qca_fun does.
    dist = (
        np.array(
            [
                _attr(intr, k, path, name)
                for k in (
                    "radialDistortion1",
                    "radialDistortion2",
                    "tangentalDistortion1",
                    "tangentalDistortion2",
                )
            ]
            + [float(intr.get("radialDistortion3", 0.0))]
        )
        / scale
    )
    rot = np.array([[_attr(tr, f"r{i}{j}", path, name) for j in (1, 2, 3)] for i in (1, 2, 3)])
    centre_m = np.array([_attr(tr, k, path, name) for k in ("x", "y", "z")]) / 1000.0
    # The transform holds the camera's position (mm) and, row-wise, its world-to-camera rotation
    # in Qualisys' camera axes; convert to OpenCV's axes (+y down, +z forward).
    R = _FLIP_YZ @ rot
    t = -R @ centre_m
    avg = cam.get("avg-residual")
    return Camera(
        name=name,
        image_size=(round(width), round(height)),
        K=np.array([[fu, 0.0, cu], [0.0, fv, cv], [0.0, 0.0, 1.0]]),
        dist=dist,
        R=R,
        t=t,
        rms_px=float("nan") if avg is None else float(avg),
    )


def _read_qca(path: Path, text: str, binning: int = 1) -> list[Camera]:
    try:
        root = ET.fromstring(text.encode("utf-8"))
    except ET.ParseError as exc:
        raise InputError(f"calibration {path} is not valid Qualisys XML: {exc}") from exc
    elems = root.findall("cameras/camera")
    if not elems:
        raise InputError(f"calibration {path}: no <cameras><camera> entries")
    video = [e for e in elems if any(m in (e.get("model") or "").lower() for m in ("video", "none"))]
    cameras = [_qca_camera(e, path, float(binning)) for e in (video or elems)]
    cameras.sort(key=lambda c: _natural_key(c.name))
    return _check_names(cameras, path)


# ---------------------------------------------------------------- auto-detection


def load_calibration(path: Path | str, qualisys_binning: int = 1) -> list[Camera]:
    """Cameras from a calibration JSON (SPEC.md), Pose2Sim ``*.toml`` or Qualisys ``*.qca.txt``.

    The format is chosen by the file name, else by its first character. Raises
    :class:`InputError` for a missing, unreadable or malformed file.
    """
    p = Path(path)
    text = read_user_text(p, "calibration file")
    name = p.name.lower()
    head = text.lstrip()[:1]
    if name.endswith(".qca.txt") or name.endswith(".qca") or head == "<":
        cameras = _read_qca(p, text, qualisys_binning)
    elif name.endswith(".json") or head == "{":
        cameras = _read_json(p, text)
    elif name.endswith(".toml") or head == "[":
        cameras = _read_toml(p, text)
    else:
        raise InputError(
            f"calibration {p}: unknown format (expected .json, Pose2Sim .toml or Qualisys .qca.txt)"
        )
    log.info("calibration %s: %d cameras (%s)", p, len(cameras), ", ".join(c.name for c in cameras))
    return cameras
