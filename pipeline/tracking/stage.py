"""Detection + tracking of one multi-view frame: the pose model (full frame or ROI crops)
followed by one OC-SORT per view. Used by the offline pipeline, the benchmark and the
live runtime alike.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from pipeline.pixels import image_size
from pipeline.pose.config import PoseConfig
from pipeline.pose.detector import PoseDetector
from pipeline.pose.roi import RoiScheduler
from pipeline.tracking.ocsort import MultiViewTracker, OCSortConfig
from pipeline.tracking.types import TrackedView

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class StepTimings:
    """Where one frame's time went, seconds; ``full`` = every view whole at the full-frame size,
    ``crops`` = batch slots, ``full_views`` = views looked at whole at the full-frame size."""

    preprocess_s: float
    inference_s: float
    decode_s: float
    tracking_s: float
    full: bool
    crops: int
    reason: str
    full_views: int = 0

    @property
    def total_s(self) -> float:
        return self.preprocess_s + self.inference_s + self.decode_s + self.tracking_s


class DetectAndTrack:
    """Pose detection over all views in one batched call, then per-view OC-SORT."""

    def __init__(self, detector: PoseDetector, tracker: MultiViewTracker, roi: RoiScheduler) -> None:
        self.detector = detector
        self.tracker = tracker
        self.roi = roi

    @classmethod
    def load(cls, pose: PoseConfig, tracking: OCSortConfig, model_path: Path,
             cameras: Sequence[str]) -> DetectAndTrack:
        """The pose model (and its crop model) loaded, one tracker per camera, the ROI scheduler."""
        detector = PoseDetector.load(pose, model_path, pose.crop_model_file(model_path))
        return cls(detector, MultiViewTracker(cameras, tracking), RoiScheduler(pose))

    @property
    def cameras(self) -> tuple[str, ...]:
        return self.tracker.cameras

    def step(self, images: Sequence[NDArray[np.uint8]], frame_index: int, timestamp_s: float,
             cameras: Sequence[str] | None = None) -> tuple[tuple[TrackedView, ...], StepTimings]:
        """One multi-view frame -> tracked views and timings. images: in the order of
        ``cameras`` (default: all cameras; a frame may lack some, late or gone)."""
        cams = tuple(cameras) if cameras is not None else self.cameras
        sizes = [image_size(im) for im in images]
        expected = [self.tracker.trackers[c].predicted_boxes() for c in cams]
        plan = self.roi.plan(sizes, expected, cams)
        batch = self.detector.detect(images, cams, frame_index, timestamp_s, plan.jobs)
        t0 = time.perf_counter()
        views = self.tracker.update(batch.views)
        t1 = time.perf_counter()
        lost = [c for c, exp in zip(cams, expected, strict=True)
                if not set(exp).issubset(self.tracker.trackers[c].last_matched)]
        self.roi.report(lost)
        if lost:
            log.debug("frame %d: a tracked person was not found in %s; full frame there next",
                      frame_index, ", ".join(lost))
        timings = StepTimings(batch.preprocess_s, batch.inference_s, batch.decode_s, t1 - t0,
                              plan.full, len(plan.jobs), plan.reason, len(plan.full_views))
        return tuple(views), timings
