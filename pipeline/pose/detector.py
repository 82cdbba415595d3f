"""Multi-view 2D pose detection: YOLO-pose on ONNX Runtime, batched over the views of a frame.

Every view of a frame (or a region of it, in ROI mode) is letterboxed into its network
rectangle; slots of equal size form one batch and go through one ``session.run``, and
each slot's output is decoded, suppressed and mapped back to its own image pixels as
:class:`ViewDetections`. With ``parallel`` > 1 the batches are split over that many
threads, each running single-threaded model calls side by side (onnxruntime releases
the GIL): on a few cores shared with video decoders this keeps the cores busier than
onnxruntime's own per-operator threading, whose threads wait for each other at every
operator when one of them is pre-empted.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError, ModelError
from pipeline.pixels import image_size
from pipeline.pose.config import PROVIDERS, PoseConfig
from pipeline.pose.decode import OUTPUT_CHANNELS, RawPoses, decode, iou_matrix, nms
from pipeline.pose.preprocess import Letterbox, fit_region, letterbox_into, net_size_for
from pipeline.pose.types import Job, Region, ViewDetections
from pipeline.skeleton import NUM_JOINTS

log = logging.getLogger(__name__)

U8 = NDArray[np.uint8]
EDGE_PX = 2.0  # a box this close to a crop edge inside the image is cut by the crop


@dataclass(frozen=True, slots=True)
class PoseBatch:
    """The detections of one multi-view frame and where the time went (seconds)."""

    views: tuple[ViewDetections, ...]
    letterboxes: tuple[Letterbox, ...]
    preprocess_s: float
    inference_s: float
    decode_s: float


def session_providers(config: PoseConfig, warn: bool = False) -> list[str]:
    """The onnxruntime execution providers a session of ``config`` asks for, in order: those of
    ``config.providers`` installed here, then the CPU one (always there)."""
    import onnxruntime as ort

    available = set(ort.get_available_providers())
    providers = [PROVIDERS[p] for p in config.providers if PROVIDERS[p] in available]
    missing = [p for p in config.providers if PROVIDERS[p] not in available]
    if missing and warn:
        log.warning("onnxruntime providers %s are not available here; using %s",
                    missing, providers or ["CPUExecutionProvider"])
    if "CPUExecutionProvider" not in providers:
        providers.append("CPUExecutionProvider")
    return providers


def load_session(config: PoseConfig, path: Path) -> Any:
    """An onnxruntime session for the model file ``path``; ModelError with the fix when it cannot load."""
    import onnxruntime as ort

    if not path.is_file():
        raise ModelError(f"pose model not found: {path} (run  cavewalk models prepare)")
    opts = ort.SessionOptions()
    opts.graph_optimization_level = ort.GraphOptimizationLevel.ORT_ENABLE_ALL
    opts.execution_mode = ort.ExecutionMode.ORT_SEQUENTIAL
    spin = "1" if config.spinning else "0"
    opts.add_session_config_entry("session.intra_op.allow_spinning", spin)
    opts.add_session_config_entry("session.inter_op.allow_spinning", spin)
    if config.intra_op_threads:
        opts.intra_op_num_threads = config.intra_op_threads
        opts.inter_op_num_threads = 1
    providers = session_providers(config, warn=True)
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
    """Runs the pose model over all views of a multi-view frame, batched by network size."""

    def __init__(self, session: Any, config: PoseConfig, crop_session: Any = None) -> None:
        self._session = session
        self._crop_session = crop_session  # None: crops run on the full model
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
        self._buffers: dict[int, NDArray[np.float32]] = {}  # lane -> flat input buffer, grown as needed
        self._pool: ThreadPoolExecutor | None = (
            ThreadPoolExecutor(config.runs, thread_name_prefix="pose") if config.runs > 1 else None)

    @classmethod
    def load(cls, config: PoseConfig, model_path: Path, crop_model_path: Path | None = None) -> PoseDetector:
        """Load ``model_path`` (and the crop model for ROI crops; None: crops run on ``model_path``)."""
        crop = load_session(config, crop_model_path) if crop_model_path is not None else None
        return cls(load_session(config, Path(model_path)), config, crop)

    def close(self) -> None:
        """Stop the threads of parallel runs (also done when the detector is collected)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __del__(self) -> None:
        pool = getattr(self, "_pool", None)
        if pool is not None:
            pool.shutdown(wait=False)

    @property
    def providers(self) -> list[str]:
        return list(self._session.get_providers())

    def full_net_size(self, image_size: tuple[int, int]) -> tuple[int, int]:
        """Network (w, h) for whole images of ``image_size`` (w, h)."""
        if self._fixed_hw is not None:
            return self._fixed_hw[1], self._fixed_hw[0]
        return net_size_for(image_size[0] / image_size[1], self.config.input_long_side)

    def _buffer(self, lane: int, n: int, net_size: tuple[int, int]) -> NDArray[np.float32]:
        """An input batch (n, 3, h, w) in the lane's own buffer (as big as its biggest batch yet:
        crop sizes change every frame, fresh pages for each would cost more than the copy)."""
        size = n * 3 * net_size[1] * net_size[0]
        flat = self._buffers.get(lane)
        if flat is None or flat.size < size:
            flat = self._buffers[lane] = np.empty(size, np.float32)
        return flat[:size].reshape(n, 3, net_size[1], net_size[0])

    def run(self, batch: NDArray[np.float32], crop: bool = False) -> NDArray[np.float32]:
        """Raw model output (B, 56, N) for a prepared input batch (of crops: on the crop model)."""
        session = self._crop_session if crop and self._crop_session is not None else self._session
        if self._fixed_batch is not None and batch.shape[0] != self._fixed_batch:
            outs = [session.run(None, {self._input_name: batch[i:i + 1]})[0] for i in range(len(batch))]
            return np.concatenate(outs, axis=0)
        return np.asarray(session.run(None, {self._input_name: batch})[0])

    def _lanes(self, nets: Sequence[tuple[int, int]], crops: Sequence[bool]) -> list[list[list[int]]]:
        """Slots grouped into batches of one model and network size, the batches spread over the
        lanes (threads) so that each lane has about as many input pixels; lane -> batches -> slots."""
        groups: dict[tuple[bool, tuple[int, int]], list[int]] = {}
        for k, (net, crop) in enumerate(zip(nets, crops, strict=True)):
            groups.setdefault((crop, net), []).append(k)
        batches = list(groups.values())
        lanes = self.config.runs
        while len(batches) < lanes:  # split the biggest batch while a lane would stay idle
            big = max(batches, key=len)
            if len(big) < 2:
                break
            batches.remove(big)
            batches += [big[: len(big) // 2], big[len(big) // 2:]]

        def pixels(batch: list[int]) -> int:
            return len(batch) * nets[batch[0]][0] * nets[batch[0]][1]

        out: list[list[list[int]]] = [[] for _ in range(min(lanes, len(batches)))]
        load = [0] * len(out)
        for batch in sorted(batches, key=pixels, reverse=True):  # largest first, to the least loaded
            lane = load.index(min(load))
            out[lane].append(batch)
            load[lane] += pixels(batch)
        return out

    def _run_lane(self, lane: int, batches: list[list[int]], images: Sequence[U8], jobs: Sequence[Job],
                  boxes: Sequence[Letterbox]) -> tuple[dict[int, RawPoses], tuple[float, float, float]]:
        """Letterbox, run and decode this lane's batches; raw detections per slot, and timings."""
        pre = inf = dec = 0.0
        raws: dict[int, RawPoses] = {}
        for batch_slots in batches:
            t0 = time.perf_counter()
            batch = self._buffer(lane, len(batch_slots), boxes[batch_slots[0]].net_size)
            for b, k in enumerate(batch_slots):
                letterbox_into(images[jobs[k].image], boxes[k], batch[b])
            t1 = time.perf_counter()
            out = self.run(batch, crop=jobs[batch_slots[0]].region is not None)
            t2 = time.perf_counter()
            cfg = self.config
            for b, k in enumerate(batch_slots):
                raws[k] = decode(out[b], cfg.score_threshold, cfg.nms_iou, cfg.max_people)
            t3 = time.perf_counter()
            pre, inf, dec = pre + t1 - t0, inf + t2 - t1, dec + t3 - t2
        return raws, (pre, inf, dec)

    def detect(
        self,
        images: Sequence[U8],
        cameras: Sequence[str],
        frame_index: int,
        timestamp_s: float,
        jobs: Sequence[Job | tuple[int, Region | None]] | None = None,
        net_size: tuple[int, int] | None = None,
    ) -> PoseBatch:
        """Detect people in every image (one per camera; BGR or I420, see :mod:`pipeline.pixels`).

        jobs: what goes into the batches, as :class:`Job` (image index, region or None for
            the whole image, network size or None) or (image index, region) pairs. Default:
            every whole image once. A view with several crops gets their detections merged
            (NMS across crops); detections cut by a crop edge that lies inside the image are
            dropped (the person continues outside the crop and has a crop of its own).
        net_size: network (w, h) for the crops whose job names none; whole images without
            one run at the full-frame size (``input_long_side``, the image's aspect).

        The timings are those of the slowest lane when batches run side by side.
        """
        if len(images) != len(cameras) or not images:
            raise InputError(
                f"need one image per camera, got {len(images)} images for {len(cameras)} cameras")
        t0 = time.perf_counter()
        sizes: list[tuple[int, int]] = []
        for cam, img in zip(cameras, images, strict=True):
            if not isinstance(img, np.ndarray):
                raise InputError(f"{cam}: expected an image array, got {type(img).__name__}")
            try:
                sizes.append(image_size(img))
            except ValueError as exc:
                raise InputError(f"{cam}: {exc}") from None
        slots = [Job(i) for i in range(len(images))] if jobs is None else [Job(*j) for j in jobs]
        if not slots or any(not 0 <= j.image < len(images) for j in slots):
            raise InputError(f"jobs must name images 0..{len(images) - 1}, got {[j.image for j in slots]}")
        boxes: list[Letterbox] = []
        for job in slots:
            w, h = sizes[job.image]
            net = job.net_size or (net_size if job.region is not None else None)
            if net is None or self._fixed_hw is not None:
                net = self.full_net_size(sizes[job.image])
            region = job.region if job.region is not None else (0.0, 0.0, float(w), float(h))
            boxes.append(fit_region(region, net))
        lanes = self._lanes([b.net_size for b in boxes], [j.region is not None for j in slots])
        t_setup = time.perf_counter() - t0
        if self._pool is None or len(lanes) == 1:
            results = [self._run_lane(0, lane, images, slots, boxes) for lane in lanes]
        else:
            futures = [self._pool.submit(self._run_lane, n, lane, images, slots, boxes)
                       for n, lane in enumerate(lanes)]
            results = [f.result() for f in futures]
        raws: dict[int, RawPoses] = {}
        for part, _ in results:
            raws.update(part)
        t1 = time.perf_counter()
        parts: list[list[RawPoses]] = [[] for _ in images]
        wholes: list[list[RawPoses]] = [[] for _ in images]
        for k, job in enumerate(slots):
            cropped = job.region is not None
            found = to_image(raws[k], boxes[k], sizes[job.image], cropped=cropped)
            (parts if cropped else wholes)[job.image].append(found)
        views = []
        for i, cam in enumerate(cameras):
            if parts[i] and wholes[i]:  # crops + a look at the whole view (finds who walked in)
                merged = merge(parts[i], self.config.nms_iou, self.config.max_people, wholes[i])
            else:
                merged = merge(parts[i] or wholes[i], self.config.nms_iou, self.config.max_people)
            views.append(ViewDetections(cam, frame_index, timestamp_s, sizes[i], merged.boxes_xyxy,
                                        merged.scores, merged.keypoints_xy, merged.keypoint_scores))
        t_merge = time.perf_counter() - t1
        pre, inf, dec = max((t for _, t in results), key=sum)
        return PoseBatch(tuple(views), tuple(boxes), t_setup + pre, inf, dec + t_merge)


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


def _concat(parts: Sequence[RawPoses]) -> RawPoses:
    if not parts:
        return RawPoses(np.zeros((0, 4), np.float32), np.zeros((0,), np.float32),
                        np.zeros((0, NUM_JOINTS, 2), np.float32), np.zeros((0, NUM_JOINTS), np.float32))
    return RawPoses(
        np.concatenate([p.boxes_xyxy for p in parts]), np.concatenate([p.scores for p in parts]),
        np.concatenate([p.keypoints_xy for p in parts]), np.concatenate([p.keypoint_scores for p in parts]),
    )


def merge(parts: Sequence[RawPoses], iou_threshold: float, max_people: int,
          extra: Sequence[RawPoses] = ()) -> RawPoses:
    """One view's detections from several crops, duplicates removed by NMS; then those of
    ``extra`` (a coarser look at the whole view) that overlap none of them: a person found in
    a crop keeps the crop's finer keypoints, whatever the scores."""
    if len(parts) == 1 and not extra:
        return parts[0]
    allp = _concat(parts)
    kept = allp.take(nms(allp.boxes_xyxy, allp.scores, iou_threshold, max_out=max_people))
    if not extra:
        return kept
    more = _concat(extra)
    more = more.take(nms(more.boxes_xyxy, more.scores, iou_threshold, max_out=max_people))
    if len(kept) and len(more):
        overlap = iou_matrix(more.boxes_xyxy, kept.boxes_xyxy).max(axis=1)
        more = more.take(np.flatnonzero(overlap < iou_threshold))
    both = _concat([kept, more])
    return both.take(np.arange(min(len(both), max_people)))
