"""INT8 static quantization of the pose model (onnxruntime QDQ, calibrated on the demo videos).

The backbone, the neck and the class branch of the head run in int8 (per-channel S8
weights, U8 activations, MinMax ranges from real whole frames and ROI-style crops); the
box and keypoint branches, the class branch's last 1x1 convolutions and the decoding
that turns the head's outputs into pixels stay in float32: their values are pixel
coordinates, where one U8 step would be several pixels. With the box branch in int8 too
the model is a little faster, but in ROI mode it lost the demo subject in one crop of
cam01 (boxes touching the crop edge are dropped), which broke its track for 3 frames.
Measured on the Pose2Sim demo (a 2-core machine with AVX-512 VNNI): keypoints a median
4.4 px (1088x1920 images) from the float32 model's; see ``scripts/bench_detect.py``.

Weights use 7 of their 8 bits (``reduce_range``). Without VNNI (AVX2 only, e.g. AMD Zen 3)
onnxruntime's U8S8 kernels add pairs of products in saturating 16-bit lanes, which full-range
weights overflow: with the same files and packages the int8 model moved the demo boxes (IoU
10th percentile 0.902 against float32, where our check needs 0.95; worst box 0.67) on a Zen 3,
and passed on AVX-512 VNNI. With 7-bit weights it is 0.963 (worst 0.75), keypoints a median
5.1 px, on the Zen 3 (issue 15 S2). ``cavewalk models prepare`` checks every int8 file
against float32 on the demo frames on the machine it runs on and keeps float32 when it misses.

Only ``cavewalk models prepare`` runs this (through :mod:`pipeline.pose.prepare`).
"""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.errors import ModelError
from pipeline.pose.config import PoseConfig
from pipeline.pose.decode import iou_matrix
from pipeline.pose.detector import PoseDetector
from pipeline.pose.preprocess import expand_to_aspect, fit_region, letterbox_into, net_size_for
from pipeline.pose.roi import with_margin
from pipeline.pose.types import ViewDetections

log = logging.getLogger(__name__)

F32 = NDArray[np.float32]
Region = tuple[float, float, float, float]
HEAD_PREFIX = "/model.23/"  # the YOLO11 pose head (Ultralytics' module index 23)
QUANTIZED_BRANCHES = ("/cv3.",)  # the class convolution stack; /cv2. = boxes, /cv4. = keypoints
# names what was quantized and how; an int8 file made by another recipe is made again
RECIPE = "qdq-u8s8-perchannel-minmax-7bit-weights; int8: backbone, neck, class branch"
CALIBRATION_EVERY = 12  # every this many frames of each video
CROP_ASPECT = 0.6  # crops around the people found, like the ROI mode's (w / h)
CROP_MARGIN = 0.1


@dataclass(frozen=True, slots=True)
class Int8Recipe:
    """How the int8 copy is made. name: recorded in the model's JSON (a file made by another
    recipe is made again). every: calibration frames, every this many of each video.
    keep_head_fp32: the box/keypoint branches and decoding stay float32 (see
    :func:`excluded_head_nodes`). max_inputs: at most this many calibration inputs (None = all).
    reduce_range: weights in 7 bits.
    The default is the shipped recipe; tests make a deliberately degraded one."""

    name: str = RECIPE
    every: int = CALIBRATION_EVERY
    keep_head_fp32: bool = True
    max_inputs: int | None = None
    reduce_range: bool = True  # 7-bit weights: no saturation in AVX2's 16-bit sums (module docstring)


DEFAULT_RECIPE = Int8Recipe()

# -- the int8 check of `cavewalk models prepare` (the criteria of tests/pipeline/pose/test_int8.py)
AGREEMENT_FRAMES = (10, 55, 90)  # frames of each demo video the int8 model is checked on
# ROI-style crops: the fp32 boxes grown as the ROI mode grows them (PoseConfig.roi_margin x the
# box's larger side on every side). A fixed 40 px pad once left a person 1-2 px from a crop edge,
# where the edge rule (a person cut by the crop is dropped) flips on a pixel: fp32 dropped them,
# int8 kept them, and a sound int8 model was refused on a fresh install (2026-12-04).
AGREEMENT_CROP_MARGIN = PoseConfig().roi_margin
AGREEMENT_CROP_NET = (192, 320)  # ... run at this network size (w, h)
KEYPOINT_SCORE = 0.5  # keypoints compared where both models are at least this sure
MIN_BOX_IOU = 0.6  # the worst matched box
P10_BOX_IOU = 0.95  # the 10th percentile of matched boxes
MAX_MEDIAN_KEYPOINT_PX = 6.0  # median keypoint distance, px of the 1088x1920 demo images
MIN_KEYPOINTS = 100  # enough keypoints compared for the median to mean something


@dataclass(frozen=True, slots=True)
class Int8Agreement:
    """How the int8 model agrees with float32 on the demo frames.

    views: views compared (whole frames and crops); count_mismatches: ``camera: fp32 n, int8 m``
    where they found different numbers of people; box IoU of each fp32 box with its best int8
    box (min and 10th percentile); median distance of keypoints both are sure of, px."""

    views: int
    count_mismatches: tuple[str, ...]
    min_iou: float
    p10_iou: float
    median_keypoint_px: float
    keypoints: int
    failures: tuple[str, ...] = field(default_factory=tuple)

    @property
    def ok(self) -> bool:
        return not self.failures

    def as_dict(self) -> dict[str, object]:
        return {"views": self.views, "count_mismatches": list(self.count_mismatches),
                "min_box_iou": round(self.min_iou, 4), "p10_box_iou": round(self.p10_iou, 4),
                "median_keypoint_px": round(self.median_keypoint_px, 3), "keypoints": self.keypoints,
                "criteria": check_criteria(),
                "ok": self.ok, "failures": list(self.failures)}


def check_criteria() -> dict[str, float]:
    """What the int8 check asks and how it looks, as recorded in each int8 model's JSON: a model
    refused under other criteria is checked again (``cavewalk models prepare``)."""
    return {"min_box_iou": MIN_BOX_IOU, "p10_box_iou": P10_BOX_IOU,
            "max_median_keypoint_px": MAX_MEDIAN_KEYPOINT_PX, "min_keypoints": MIN_KEYPOINTS,
            "crop_margin": AGREEMENT_CROP_MARGIN}


Views = list[tuple[list[str], list[NDArray[np.uint8]]]]


def agreement_frames(videos: Mapping[str, Path], frames: Sequence[int] = AGREEMENT_FRAMES) -> Views:
    """(cameras, images) for each of ``frames``, one image per video (cameras sorted)."""
    cams = sorted(videos)
    out: Views = [(cams, []) for _ in frames]
    for cam in cams:
        cap = cv2.VideoCapture(str(videos[cam]))
        try:
            for k, index in enumerate(frames):
                cap.set(cv2.CAP_PROP_POS_FRAMES, index)
                ok, image = cap.read()
                if not ok:
                    raise ModelError(f"int8 check: frame {index} of {videos[cam]} does not decode")
                out[k][1].append(image)
        finally:
            cap.release()
    return out


def int8_agreement(fp32_model: Path, int8_model: Path, videos: Mapping[str, Path],
                   crops_only: bool = False, jobs_model: Path | None = None) -> Int8Agreement:
    """Compare ``int8_model`` with ``fp32_model`` on :data:`AGREEMENT_FRAMES` of the demo videos:
    whole frames (unless ``crops_only``, for the crop model) and ROI-style crops around the people
    ``jobs_model`` (default ``fp32_model``) finds in the whole frames."""
    config = PoseConfig(parallel=1)  # one lane: the same batches, the same figures, every time
    fp32 = PoseDetector.load(config, fp32_model)
    int8 = PoseDetector.load(config, int8_model)
    finder = fp32 if jobs_model is None else PoseDetector.load(config, jobs_model)
    pairs: list[tuple[ViewDetections, ViewDetections]] = []
    try:
        for cams, images in agreement_frames(videos):
            found = finder.detect(images, cams, 0, 0.0)
            jobs = [(i, with_margin(b, AGREEMENT_CROP_MARGIN)) for i, v in enumerate(found.views)
                    for b in v.boxes_xyxy]
            if not crops_only:
                pairs += list(zip(fp32.detect(images, cams, 0, 0.0).views,
                                  int8.detect(images, cams, 0, 0.0).views, strict=True))
            if jobs:
                pairs += list(zip(fp32.detect(images, cams, 0, 0.0, jobs, AGREEMENT_CROP_NET).views,
                                  int8.detect(images, cams, 0, 0.0, jobs, AGREEMENT_CROP_NET).views,
                                  strict=True))
    finally:
        for d in {id(x): x for x in (fp32, int8, finder)}.values():
            d.close()
    return agreement_of(pairs, "int8")


def agreement_of(pairs: Sequence[tuple[ViewDetections, ViewDetections]], name: str = "int8") -> Int8Agreement:
    """How the detections of a candidate (the second of each pair) agree with the float32
    reference's (the first), by the int8 check's criteria (:data:`MIN_BOX_IOU`,
    :data:`P10_BOX_IOU`, :data:`MAX_MEDIAN_KEYPOINT_PX`, the same people in every view);
    ``name`` names the candidate in the messages."""
    ious: list[float] = []
    distances: list[float] = []
    mismatches: list[str] = []
    views = 0
    for a, b in pairs:
        views += 1
        if len(a) != len(b):
            mismatches.append(f"{a.camera}: fp32 {len(a)}, {name} {len(b)}")
        if not len(a) or not len(b):
            continue
        iou = iou_matrix(a.boxes_xyxy, b.boxes_xyxy)
        ious.extend(iou.max(axis=1).tolist())
        for i, j in enumerate(iou.argmax(axis=1)):
            both = (a.keypoint_scores[i] >= KEYPOINT_SCORE) & (b.keypoint_scores[j] >= KEYPOINT_SCORE)
            d = np.linalg.norm(a.keypoints_xy[i] - b.keypoints_xy[j], axis=1)[both]
            distances.extend(d.tolist())
    min_iou = min(ious) if ious else 0.0
    p10 = float(np.percentile(ious, 10)) if ious else 0.0
    median = float(np.median(distances)) if distances else float("inf")
    failures = []
    if mismatches:
        failures.append(f"it finds other numbers of people ({'; '.join(mismatches[:4])})")
    if min_iou <= MIN_BOX_IOU:
        failures.append(f"its worst box has IoU {min_iou:.2f} with fp32's (needs > {MIN_BOX_IOU})")
    if p10 <= P10_BOX_IOU:
        failures.append(f"its boxes moved: IoU 10th percentile {p10:.3f} (needs > {P10_BOX_IOU})")
    if len(distances) < MIN_KEYPOINTS:
        failures.append(f"only {len(distances)} keypoints to compare (needs {MIN_KEYPOINTS})")
    elif median >= MAX_MEDIAN_KEYPOINT_PX:
        failures.append(f"its keypoints are a median {median:.1f} px from fp32's "
                        f"(needs < {MAX_MEDIAN_KEYPOINT_PX})")
    return Int8Agreement(views, tuple(mismatches), min_iou, p10, median, len(distances), tuple(failures))


def excluded_head_nodes(node_names: Iterable[str]) -> list[str]:
    """The nodes that stay float32: everything in the head except the box/class convolution
    stacks, and those stacks' last 1x1 convolutions (``cv2.i.2``, ``cv3.i.2``).

    >>> excluded_head_nodes(["/model.0/conv/Conv", "/model.23/cv2.0/cv2.0.0/conv/Conv",
    ...     "/model.23/cv2.0/cv2.0.2/Conv", "/model.23/cv4.1/cv4.1.0/conv/Conv", "/model.23/dfl/conv/Conv"])
    ['/model.23/cv2.0/cv2.0.2/Conv', '/model.23/cv4.1/cv4.1.0/conv/Conv', '/model.23/dfl/conv/Conv']
    """
    out = []
    for name in node_names:
        if not name.startswith(HEAD_PREFIX):
            continue
        branch = next((b for b in QUANTIZED_BRANCHES if b in name), None)
        last = branch is not None and any(f"{branch}{i}.2/" in name for i in range(3))
        if branch is None or last:
            out.append(name)
    return out


def calibration_inputs(
    videos: Mapping[str, Path],
    fp32_model: Path,
    full_long_side: int = 640,
    crop_long_side: int = 320,
    every: int = CALIBRATION_EVERY,
) -> list[F32]:
    """Network inputs (1, 3, h, w) as the detector makes them, from every ``every``-th frame
    of each video: the whole frame at ``full_long_side`` and at ``crop_long_side``, and crops
    around the people the float32 model finds, at ``crop_long_side``."""
    detector = PoseDetector.load(PoseConfig(parallel=1), fp32_model)  # one lane: a reproducible order
    crop_net = net_size_for(CROP_ASPECT, crop_long_side)
    inputs: list[F32] = []

    def add(image: NDArray[np.uint8], region: Region, net: tuple[int, int]) -> None:
        x = np.empty((1, 3, net[1], net[0]), np.float32)
        letterbox_into(image, fit_region(region, net), x[0])
        inputs.append(x)

    for camera, path in sorted(videos.items()):  # a fixed order: the same inputs, the same ranges
        cap = cv2.VideoCapture(str(path))
        if not cap.isOpened():
            raise ModelError(f"calibration video {path} does not open")
        try:
            index = 0
            while cap.grab():
                if index % every == 0:
                    ok, image = cap.retrieve()
                    if not ok:
                        break
                    h, w = image.shape[:2]
                    whole = (0.0, 0.0, float(w), float(h))
                    add(image, whole, net_size_for(w / h, full_long_side))
                    add(image, whole, net_size_for(w / h, crop_long_side))
                    found = detector.detect([image], [camera], index, 0.0)
                    for box in found.views[0].boxes_xyxy:
                        x1, y1, x2, y2 = (float(v) for v in box)
                        add(image, expand_to_aspect((x1, y1, x2, y2), CROP_ASPECT, CROP_MARGIN), crop_net)
                index += 1
        finally:
            cap.release()
    if not inputs:
        raise ModelError(f"no calibration frames could be read from {sorted(videos)}")
    return inputs


def quantize_pose_model(fp32_model: Path, out_path: Path, inputs: Sequence[F32],
                        keep_head_fp32: bool = True, reduce_range: bool = True) -> int:
    """Write the int8 QDQ model calibrated on ``inputs``; returns how many nodes stayed float32
    (with ``keep_head_fp32`` off, none: a degraded model, for tests of the int8 check)."""
    import onnx
    from onnxruntime.quantization import (
        CalibrationDataReader,
        CalibrationMethod,
        QuantFormat,
        QuantType,
        quantize_static,
    )
    from onnxruntime.quantization.shape_inference import quant_pre_process

    class Reader(CalibrationDataReader):  # type: ignore[misc]
        def __init__(self, name: str) -> None:
            self._name = name
            self._it = iter(inputs)

        def get_next(self) -> dict[str, F32] | None:
            x = next(self._it, None)
            return None if x is None else {self._name: x}

    with tempfile.TemporaryDirectory() as tmp:
        pre = Path(tmp) / "pre.onnx"
        # the head's shape arithmetic defeats symbolic shape inference; ONNX's own is enough
        quant_pre_process(str(fp32_model), str(pre), skip_symbolic_shape=True)
        model = onnx.load(str(pre))
        excluded = excluded_head_nodes(n.name for n in model.graph.node) if keep_head_fp32 else []
        input_name = model.graph.input[0].name
        del model
        try:
            quantize_static(
                str(pre), str(out_path), Reader(input_name),
                quant_format=QuantFormat.QDQ, per_channel=True,
                activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8,
                nodes_to_exclude=excluded, calibrate_method=CalibrationMethod.MinMax,
                reduce_range=reduce_range,
            )
        except Exception as exc:  # onnxruntime raises many kinds
            raise ModelError(f"int8 quantization of {fp32_model} failed: {exc}") from exc
    return len(excluded)
