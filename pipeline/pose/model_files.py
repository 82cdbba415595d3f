"""The pose model's file names: where ``cavewalk models prepare`` puts each model and where the
detector finds it (the one place these names are spelled).

In the models folder: ``yolo11n-pose.onnx`` (float32), ``yolo11n-pose.int8.onnx`` (its int8
copy), and beside each the *crop model* for ROI crops (``yolo11n-pose.crop.onnx``,
``yolo11n-pose.crop.int8.onnx``), each with a ``.json`` of how it was made.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path
from typing import Literal

log = logging.getLogger(__name__)

POSE_MODEL_NAME = "yolo11n-pose"
INT8_SUFFIX = ".int8"  # yolo11n-pose.int8.onnx
CROP_SUFFIX = ".crop"  # yolo11n-pose.crop.onnx, yolo11n-pose.crop.int8.onnx

Precision = Literal["fp32", "int8"]


def pose_model_file(models_dir: Path, precision: Precision = "fp32") -> Path:
    """The prepared pose model of ``precision`` in ``models_dir``."""
    fp32 = Path(models_dir) / f"{POSE_MODEL_NAME}.onnx"
    return int8_path(fp32) if precision == "int8" else fp32


def int8_path(fp32_path: Path) -> Path:
    """Where the int8 copy of a model lives: ``x.onnx`` -> ``x.int8.onnx``."""
    return fp32_path.with_name(f"{fp32_path.stem}{INT8_SUFFIX}{fp32_path.suffix}")


def crop_model_path(model_path: Path) -> Path:
    """Where the crop model of a model file lives: ``x.onnx`` -> ``x.crop.onnx``,
    ``x.int8.onnx`` -> ``x.crop.int8.onnx``."""
    base, _, rest = model_path.name.partition(".")
    return model_path.with_name(f"{base}{CROP_SUFFIX}.{rest}")


def rejected_int8(path: Path) -> str | None:
    """Why ``cavewalk models prepare`` did not keep the int8 file ``path`` (its JSON says), or None."""
    meta_path = path.with_suffix(".json")
    if path.is_file() or not meta_path.is_file():
        return None
    try:
        meta = json.loads(meta_path.read_text())
    except (OSError, ValueError):
        return None
    reason = meta.get("rejected") if isinstance(meta, dict) else None
    return str(reason) if reason else None


def usable_model_path(path: Path) -> Path:
    """``path``, or the float32 model an int8 ``path`` was made from when ``models prepare``
    rejected the int8 copy (it missed the int8 check against float32 on the demo frames)."""
    reason = rejected_int8(path)
    if reason is None or INT8_SUFFIX not in path.name:
        return path
    fp32 = path.with_name(path.name.replace(INT8_SUFFIX, "", 1))
    log.warning("%s was not kept by `cavewalk models prepare` (%s); using the float32 %s",
                path.name, reason, fp32.name)
    return fp32
