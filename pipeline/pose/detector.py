"""Multi-view 2D pose detection: YOLO-pose on ONNX Runtime, one batched call per multi-view frame.

Every view of a frame (or a region of it, in ROI mode) is letterboxed into the same
network rectangle, the batch goes through one ``session.run``, and each image's output
is decoded, suppressed and mapped back to its own image pixels as :class:`ViewDetections`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError, ModelError
from pipeline.pose.decode import OUTPUT_CHANNELS, RawPoses, decode, nms
from pipeline.pose.preprocess import Letterbox, fit_region, letterbox_into, net_size_for
from pipeline.pose.types import ViewDetections
from pipeline.skeleton import NUM_JOINTS

log = logging.getLogger(__name__)

U8 = NDArray[np.uint8]
Region = tuple[float, float, float, float]
PROVIDERS = {"cpu": "CPUExecutionProvider", "cuda": "CUDAExecutionProvider"}
EDGE_PX = 2.0  # a box this close to a crop edge inside the image is cut by the crop


class PoseSettingsLike(Protocol):
    """The fields of ``app.core.config.PoseSettings`` the detector reads (pipeline never imports app)."""

    @property
    def input_long_side(self) -> int: ...
    @property
    def score_threshold(self) -> float: ...
    @property
    def nms_iou(self) -> float: ...
    @property
    def providers(self) -> Sequence[str]: ...
    @property
    def threads(self) -> int: ...


@dataclass(frozen=True, slots=True)
class PoseDetectorConfig:
    """How to run the pose model.

    model_path: a YOLO-pose ONNX file with output (B, 56, N).
    input_long_side: long side of the full-frame network input, px (multiple of 32); the
        short side follows the images' aspect (1088x1920 portrait -> 384x640).
    score_threshold: minimum person score. nms_iou: IoU above which NMS drops a box.
    providers: ``"cpu"`` and/or ``"cuda"``, in order of preference.
    threads: onnxruntime intra-op threads (0 = its own choice).
    max_people: at most this many people per image.
    spinning: let onnxruntime's idle threads spin-wait between runs (faster alone on a
        machine, but it takes CPU from video decoders and other processes on few cores).
    """

    model_path: Path
    input_long_side: int = 640
    score_threshold: float = 0.35
    nms_iou: float = 0.6
    providers: tuple[str, ...] = ("cpu",)
    threads: int = 0
    max_people: int = 16
    spinning: bool = False

    def __post_init__(self) -> None:
        if self.input_long_side <= 0 or self.input_long_side % 32:
            raise ValueError(f"input_long_side must be a positive multiple of 32, got {self.input_long_side}")
        for name in ("score_threshold", "nms_iou"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {v}")
        unknown = [p for p in self.providers if p not in PROVIDERS]
        if unknown or not self.providers:
            raise ValueError(
                f"providers must be a non-empty subset of {sorted(PROVIDERS)}, got {self.providers}")
        if self.threads < 0 or self.max_people <= 0:
            raise ValueError(
                f"threads must be >= 0 and max_people > 0, got {self.threads}, {self.max_people}")

    @classmethod
    def from_settings(cls, pose: PoseSettingsLike, model_path: Path) -> PoseDetectorConfig:
        return cls(
            model_path=Path(model_path),
            input_long_side=int(pose.input_long_side),
            score_threshold=float(pose.score_threshold),
            nms_iou=float(pose.nms_iou),
            providers=tuple(pose.providers),
            threads=int(pose.threads),
        )


@dataclass(frozen=True, slots=True)
class PoseBatch:
    """The detections of one multi-view frame and where the time went (seconds)."""

    views: tuple[ViewDetections, ...]
    letterboxes: tuple[Letterbox, ...]
    preprocess_s: float
    inference_s: float
    decode_s: float


def load_session(config: PoseDetectorConfig) -> Any:
    """An onnxruntime session for the model; ModelError with the fix when it cannot load."""
    import onnxruntime as ort

    path = config.model_path
    if not path.is_file():
        raise ModelError(f"pose model not found: {path} (run  cavewalk models prepare)")
    opts = ort.SessionOptions()
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    spin = "1" if config.spinning else "0"
    opts.add_session_config_entry("session.intra_op.allow_spinning", spin)
    opts.add_session_config_entry("session.inter_op.allow_spinning", spin)
    if config.threads:
        opts.intra_op_num_threads = config.threads
        opts.inter_op_num_threads = 1
    available = set(ort.get_available_providers())
    providers = [PROVIDERS[p] for p in config.providers if PROVIDERS[p] in available]
    missing = [p for p in config.providers if PROVIDERS[p] not in available]
    if missing:
        log.warning("onnxruntime providers %s are not available here; using %s",
                    missing, providers or ["CPUExecutionProvider"])
    if "CPUExecutionProvider" not in providers:
        providers.append("CPUExecutionProvider")
    try:
        session = ort.InferenceSession(str(path), opts, providers=providers)
    except Exception as exc:  # onnxruntime raises its own exception types
        raise ModelError(f"{path}: onnxruntime cannot load it ({exc})") from exc
    inputs = session.get_inputs()
    if len(inputs) != 1 or len(inputs[0].shape) != 4:
        raise ModelError(f"{path}: expected one (B, 3, H, W) input, got {[i.shape for i in inputs]}")
    out = session.get_outputs()[0].shape
    if len(out) != 3 or (isinstance(out[1], int) and out[1] != OUTPUT_CHANNELS):
        raise ModelError(f"{path}: expected a YOLO-pose output (B, {OUTPUT_CHANNELS}, N), got {out}")
    log.info("pose model %s on %s", path.name, session.get_providers()[0])
    return session


class PoseDetector:
    """Runs the pose model over all views of a multi-view frame in one batched call."""

    def __init__(self, session: Any, config: PoseDetectorConfig) -> None:
        self._session = session
        self.config = config
        inp = session.get_inputs()[0]
        self._input_name: str = inp.name
        shape = inp.shape
        # a model exported with a fixed size accepts only that size
        self._fixed_hw: tuple[int, int] | None = (
            (int(shape[2]), int(shape[3]))
            if isinstance(shape[2], int) and isinstance(shape[3], int) else None
        )
        self._fixed_batch: int | None = int(shape[0]) if isinstance(shape[0], int) else None
        self._buffer: NDArray[np.float32] = np.zeros((0, 3, 1, 1), np.float32)

    @classmethod
    def load(cls, config: PoseDetectorConfig) -> PoseDetector:
        return cls(load_session(config), config)

    @classmethod
    def from_settings(cls, pose: PoseSettingsLike, model_path: Path) -> PoseDetector:
        return cls.load(PoseDetectorConfig.from_settings(pose, model_path))

    @property
    def providers(self) -> list[str]:
        return list(self._session.get_providers())

    def full_net_size(self, image_size: tuple[int, int]) -> tuple[int, int]:
        """Network (w, h) for whole images of ``image_size`` (w, h)."""
        if self._fixed_hw is not None:
            return self._fixed_hw[1], self._fixed_hw[0]
        return net_size_for(image_size[0] / image_size[1], self.config.input_long_side)

    def _batch_buffer(self, n: int, net_size: tuple[int, int]) -> NDArray[np.float32]:
        shape = (n, 3, net_size[1], net_size[0])
        if self._buffer.shape != shape:
            self._buffer = np.empty(shape, np.float32)
        return self._buffer

    def run(self, batch: NDArray[np.float32]) -> NDArray[np.float32]:
        """Raw model output (B, 56, N) for a prepared input batch."""
        if self._fixed_batch is not None and batch.shape[0] != self._fixed_batch:
            outs = [self._session.run(None, {self._input_name: batch[i:i + 1]})[0] for i in range(len(batch))]
            return np.concatenate(outs, axis=0)
        return np.asarray(self._session.run(None, {self._input_name: batch})[0])

    def detect(
        self,
        images: Sequence[U8],
        cameras: Sequence[str],
        frame_index: int,
        timestamp_s: float,
        jobs: Sequence[tuple[int, Region | None]] | None = None,
        net_size: tuple[int, int] | None = None,
    ) -> PoseBatch:
        """Detect people in every image (one per camera) with one model call.

        jobs: what goes into the batch, as (image index, region) pairs; region
            [x1, y1, x2, y2] in image px (ROI mode) or None for the whole image. Default:
            every whole image once. A view with several crops gets their detections merged
            (NMS across crops); detections cut by a crop edge that lies inside the image are
            dropped (the person continues outside the crop and has a crop of its own).
        net_size: network (w, h) for this batch; default: from the first image's aspect and
            ``input_long_side``.
        """
        if len(images) != len(cameras) or not images:
            raise InputError(
                f"need one image per camera, got {len(images)} images for {len(cameras)} cameras")
        t0 = time.perf_counter()
        sizes: list[tuple[int, int]] = []
        for cam, img in zip(cameras, images, strict=True):
            if img is None or img.ndim != 3 or img.shape[2] != 3 or img.dtype != np.uint8:
                shape = None if img is None else (img.shape, img.dtype)
                raise InputError(f"{cam}: expected an (H, W, 3) uint8 BGR image, got {shape}")
            sizes.append((int(img.shape[1]), int(img.shape[0])))
        if jobs is None:
            jobs = [(i, None) for i in range(len(images))]
        if not jobs or any(not 0 <= j < len(images) for j, _ in jobs):
            raise InputError(f"jobs must name images 0..{len(images) - 1}, got {[j for j, _ in jobs]}")
        if net_size is None or self._fixed_hw is not None:
            net_size = self.full_net_size(sizes[0])
        boxes: list[Letterbox] = []
        batch = self._batch_buffer(len(jobs), net_size)
        for k, (i, region) in enumerate(jobs):
            w, h = sizes[i]
            lb = fit_region(region if region is not None else (0.0, 0.0, float(w), float(h)), net_size)
            letterbox_into(images[i], lb, batch[k])
            boxes.append(lb)
        t1 = time.perf_counter()
        out = self.run(batch)
        t2 = time.perf_counter()
        parts: list[list[RawPoses]] = [[] for _ in images]
        for k, (i, region) in enumerate(jobs):
            raw = decode(out[k], self.config.score_threshold, self.config.nms_iou, self.config.max_people)
            parts[i].append(to_image(raw, boxes[k], sizes[i], cropped=region is not None))
        views = []
        for i, cam in enumerate(cameras):
            merged = merge(parts[i], self.config.nms_iou, self.config.max_people)
            views.append(ViewDetections(cam, frame_index, timestamp_s, sizes[i], merged.boxes_xyxy,
                                        merged.scores, merged.keypoints_xy, merged.keypoint_scores))
        t3 = time.perf_counter()
        return PoseBatch(tuple(views), tuple(boxes), t1 - t0, t2 - t1, t3 - t2)


def to_image(raw: RawPoses, box: Letterbox, image_size: tuple[int, int], cropped: bool = False) -> RawPoses:
    """Map network-input detections back to image pixels (boxes clipped to the image).

    With ``cropped``, detections touching an edge of the crop that lies inside the image
    are dropped: they are people cut by the crop.
    """
    if len(raw) == 0:
        return raw
    w, h = image_size
    if cropped:
        xyxy_net = raw.boxes_xyxy
        nw, nh = box.net_size
        rx1, ry1, rx2, ry2 = box.region_xyxy
        # the crop's edges in network px (the letterbox may pad around the region)
        e = box.to_net(np.array([[rx1, ry1], [rx2, ry2]], np.float32))
        ex1, ey1 = max(float(e[0, 0]), 0.0), max(float(e[0, 1]), 0.0)
        ex2, ey2 = min(float(e[1, 0]), float(nw)), min(float(e[1, 1]), float(nh))
        cut = np.zeros(len(raw), dtype=bool)
        if rx1 > 0:
            cut |= xyxy_net[:, 0] <= ex1 + EDGE_PX
        if ry1 > 0:
            cut |= xyxy_net[:, 1] <= ey1 + EDGE_PX
        if rx2 < w:
            cut |= xyxy_net[:, 2] >= ex2 - EDGE_PX
        if ry2 < h:
            cut |= xyxy_net[:, 3] >= ey2 - EDGE_PX
        raw = raw.take(np.flatnonzero(~cut))
    xyxy = box.to_image(raw.boxes_xyxy.reshape(-1, 2, 2)).reshape(-1, 4)
    xyxy[:, [0, 2]] = np.clip(xyxy[:, [0, 2]], 0, w)
    xyxy[:, [1, 3]] = np.clip(xyxy[:, [1, 3]], 0, h)
    return RawPoses(xyxy, raw.scores, box.to_image(raw.keypoints_xy), raw.keypoint_scores)


def merge(parts: Sequence[RawPoses], iou_threshold: float, max_people: int) -> RawPoses:
    """One view's detections from several crops, duplicates removed by NMS."""
    if len(parts) == 1:
        return parts[0]
    if not parts:
        return RawPoses(np.zeros((0, 4), np.float32), np.zeros((0,), np.float32),
                        np.zeros((0, NUM_JOINTS, 2), np.float32), np.zeros((0, NUM_JOINTS), np.float32))
    allp = RawPoses(
        np.concatenate([p.boxes_xyxy for p in parts]), np.concatenate([p.scores for p in parts]),
        np.concatenate([p.keypoints_xy for p in parts]), np.concatenate([p.keypoint_scores for p in parts]),
    )
    return allp.take(nms(allp.boxes_xyxy, allp.scores, iou_threshold, max_out=max_people))
