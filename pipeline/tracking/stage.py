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
from pipeline.pose.stagger import ViewBudget, choose_views
from pipeline.tracking.carry import Seen, carried_detections
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
    detected_views: int = 0  # views the model looked at (the others carried their people)

    @property
    def total_s(self) -> float:
        return self.preprocess_s + self.inference_s + self.decode_s + self.tracking_s


class DetectAndTrack:
    """Pose detection over all views in one batched call, then per-view OC-SORT."""

    def __init__(self, detector: PoseDetector, tracker: MultiViewTracker, roi: RoiScheduler,
                 budget: ViewBudget | None = None) -> None:
        self.detector = detector
        self.tracker = tracker
        self.roi = roi
        self.budget = budget if budget is not None else ViewBudget(roi.config)
        self._since: dict[str, int] = {}  # camera -> frames since the model last looked at it
        self._seen: dict[str, dict[int, Seen]] = {}  # camera -> track id -> its last detection

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
        k = self.budget.views(len(cams))
        detect = None
        if k < len(cams):  # staggered: the views that need a look, then the most overdue
            attention = self.roi.attention(cams) | {
                i for i, c in enumerate(cams) if self._unconfirmed(c)}
            detect = choose_views(k, [self._since.get(c, 1 << 30) for c in cams], attention)
        plan = self.roi.plan(sizes, expected, cams, detect)
        looked = plan.detected if plan.detected is not None else frozenset(range(len(cams)))
        batch = self.detector.detect(images, cams, frame_index, timestamp_s, plan.jobs)
        t0 = time.perf_counter()
        cfg = self.roi.config
        fed = [view if i in looked else
               carried_detections(self.tracker.trackers[cams[i]], frame_index, timestamp_s, sizes[i],
                                  cfg.carry_decay, cfg.carry_keypoint_decay, self._seen.get(cams[i]))
               for i, view in enumerate(batch.views)]
        views = self.tracker.update(fed)
        if detect is not None or self._seen:
            self._remember(cams, views, looked, frame_index)
        t1 = time.perf_counter()
        for i, c in enumerate(cams):
            self._since[c] = 0 if i in looked else self._since.get(c, 0) + 1
        lost = [c for i, (c, exp) in enumerate(zip(cams, expected, strict=True))
                if i in looked and not set(exp).issubset(self.tracker.trackers[c].last_matched)]
        self.roi.report(lost)
        self.budget.update(timestamp_s)
        if lost:
            log.debug("frame %d: a tracked person was not found in %s; full frame there next",
                      frame_index, ", ".join(lost))
        timings = StepTimings(batch.preprocess_s, batch.inference_s, batch.decode_s, t1 - t0,
                              plan.full, len(plan.jobs), plan.reason, len(plan.full_views), len(looked))
        return tuple(views), timings

    def _remember(self, cams: Sequence[str], views: Sequence[TrackedView], looked: frozenset[int],
                  frame_index: int) -> None:
        """The last detection of every person reported in a view the model looked at."""
        by_cam = {v.camera: v for v in views}
        for i, cam in enumerate(cams):
            view = by_cam.get(cam)
            if i not in looked or view is None:
                continue
            seen = self._seen.setdefault(cam, {})
            live = {t.track_id for t in self.tracker.trackers[cam].tracks}
            for tid in [t for t in seen if t not in live]:
                del seen[tid]
            boxes, kps, scores = view.boxes_xyxy, view.keypoints_xy, view.keypoint_scores
            for row, tid in enumerate(view.track_ids.tolist()):
                seen[tid] = Seen(frame_index, boxes[row].astype(np.float64), kps[row].copy(),
                                 scores[row].copy())

    def _unconfirmed(self, camera: str) -> bool:
        """A person in this view the tracker has not confirmed yet (a newcomer: detect them)."""
        tracker = self.tracker.trackers[camera]
        need = max(tracker.config.min_hits, 1)
        return any(t.time_since_update == 0 and t.hits < need for t in tracker.tracks)
