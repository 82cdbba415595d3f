"""INT8 static quantization of the pose model (onnxruntime QDQ, calibrated on the demo videos).

The backbone, the neck and the class branch of the head run in int8 (per-channel S8
weights, U8 activations, MinMax ranges from real whole frames and ROI-style crops); the
box and keypoint branches, the class branch's last 1x1 convolutions and the decoding
that turns the head's outputs into pixels stay in float32: their values are pixel
coordinates, where one U8 step would be several pixels. With the box branch in int8 too
the model is a little faster, but in ROI mode it lost the demo subject in one crop of
cam01 (boxes touching the crop edge are dropped), which broke its track for 3 frames.
Measured on the Pose2Sim demo (this 2-core machine, AVX-512 VNNI): keypoints a median
4.4 px (1088x1920 images) from the float32 model's; see ``scripts/bench_detect.py``.

Only ``cavewalk models prepare`` runs this (through :mod:`pipeline.pose.prepare`).
"""

from __future__ import annotations

import logging
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import cv2
import numpy as np
from numpy.typing import NDArray

from pipeline.errors import ModelError
from pipeline.pose.config import PoseConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.preprocess import expand_to_aspect, fit_region, letterbox_into, net_size_for

log = logging.getLogger(__name__)

F32 = NDArray[np.float32]
Region = tuple[float, float, float, float]
HEAD_PREFIX = "/model.23/"  # the YOLO11 pose head (Ultralytics' module index 23)
QUANTIZED_BRANCHES = ("/cv3.",)  # the class convolution stack; /cv2. = boxes, /cv4. = keypoints
# names what was quantized and how; an int8 file made by another recipe is made again
RECIPE = "qdq-u8s8-perchannel-minmax; int8: backbone, neck, class branch"
CALIBRATION_EVERY = 12  # every this many frames of each video
CROP_ASPECT = 0.6  # crops around the people found, like the ROI mode's (w / h)
CROP_MARGIN = 0.1


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

    for camera, path in videos.items():
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


def quantize_pose_model(fp32_model: Path, out_path: Path, inputs: Sequence[F32]) -> int:
    """Write the int8 QDQ model calibrated on ``inputs``; returns how many nodes stayed float32."""
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
        excluded = excluded_head_nodes(n.name for n in model.graph.node)
        input_name = model.graph.input[0].name
        del model
        try:
            quantize_static(
                str(pre), str(out_path), Reader(input_name),
                quant_format=QuantFormat.QDQ, per_channel=True,
                activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8,
                nodes_to_exclude=excluded, calibrate_method=CalibrationMethod.MinMax,
            )
        except Exception as exc:  # onnxruntime raises many kinds
            raise ModelError(f"int8 quantization of {fp32_model} failed: {exc}") from exc
    return len(excluded)
