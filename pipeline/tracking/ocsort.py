"""OC-SORT (Cao et al., "Observation-Centric SORT", CVPR 2023) per camera view.

SORT's Kalman tracker with the three observation-centric additions:
- ORU: a track seen again after a gap re-runs its filter along a virtual path between
  its last and new observations (:mod:`pipeline.tracking.kalman`);
- OCM: the first association adds a direction-consistency term computed from real
  observations ``delta_t`` frames apart (:func:`association.associate_ocm`);
- OCR: detections and tracks left over are matched again against the tracks' last
  real observations (:func:`association.associate_iou`).

The tracker returns which detection each track took, so keypoints and scores ride
along with their track; it never re-matches by IoU afterwards.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.pose.types import ViewDetections
from pipeline.tracking.association import associate_iou, associate_ocm, unit_direction
from pipeline.tracking.config import OCSortConfig
from pipeline.tracking.kalman import BoxKalmanFilter
from pipeline.tracking.types import TrackedView

log = logging.getLogger(__name__)

F64 = NDArray[np.float64]


@dataclass(frozen=True, slots=True)
class Observation:
    """One detection a track took: frame, box [x1, y1, x2, y2], score, keypoints (17, 2) and scores (17,)."""

    frame_index: int
    box_xyxy: F64
    score: float
    keypoints_xy: NDArray[np.float32]
    keypoint_scores: NDArray[np.float32]


@dataclass(slots=True, eq=False)
class Track:
    """One tracked person in one view (mutable tracker state)."""

    track_id: int
    kf: BoxKalmanFilter
    history: deque[Observation]
    age: int = 0  # frames since birth
    hits: int = 0
    hit_streak: int = 0
    time_since_update: int = 0
    velocity: F64 | None = None  # unit (dy, dx) of the observed motion
    observations: dict[int, F64] = field(default_factory=dict)  # age -> box, recent only
    last_observation: F64 = field(default_factory=lambda: np.full(4, np.nan))

    def previous_observation(self, delta_t: int) -> F64:
        """The observation ``delta_t`` frames back (or the closest later one, else the last)."""
        for dt in range(delta_t, 0, -1):
            box = self.observations.get(self.age - dt)
            if box is not None:
                return box
        return self.last_observation

    def observe(self, obs: Observation, delta_t: int) -> None:
        box = obs.box_xyxy
        if np.all(np.isfinite(self.last_observation)):
            self.velocity = unit_direction(self.previous_observation(delta_t), box)[0]
        self.last_observation = box
        self.observations[self.age] = box
        for k in [k for k in self.observations if k < self.age - delta_t]:
            del self.observations[k]
        self.history.append(obs)
        self.time_since_update = 0
        self.hits += 1
        self.hit_streak += 1
        self.kf.update(box)

    def predict(self) -> F64:
        box = self.kf.predict()
        self.age += 1
        if self.time_since_update > 0:
            self.hit_streak = 0
        self.time_since_update += 1
        return box

    @property
    def last(self) -> Observation:
        return self.history[-1]


class OCSort:
    """OC-SORT for one camera. Call :meth:`update` once per frame, also with no detections."""

    def __init__(self, config: OCSortConfig | None = None, camera: str = "") -> None:
        self.config = config or OCSortConfig()
        self.camera = camera
        self.frame_count = 0
        self._tracks: list[Track] = []
        self._next_id = 1
        self.last_matched: frozenset[int] = frozenset()  # ids of tracks matched in the last frame

    @property
    def tracks(self) -> tuple[Track, ...]:
        """All live tracks (reported or not)."""
        return tuple(self._tracks)

    def reset(self) -> None:
        self._tracks.clear()
        self.frame_count = 0
        self._next_id = 1

    def predicted_boxes(self, confirmed_only: bool = True) -> dict[int, F64]:
        """Track id -> box expected in the next frame (the filter is not advanced), for the
        tracks matched in the last frame (and, with ``confirmed_only``, seen min_hits times)."""
        out = {}
        for t in self._tracks:
            if t.time_since_update > 0 or (confirmed_only and t.hits < max(self.config.min_hits, 1)):
                continue
            box = t.kf.peek(1)
            if np.all(np.isfinite(box)):
                out[t.track_id] = box
        return out

    def update(self, detections: ViewDetections) -> TrackedView:
        """Associate this frame's detections; returns the reported tracks and the detection each took."""
        cfg = self.config
        self.frame_count += 1
        keep_det = np.flatnonzero(detections.box_scores >= cfg.det_thresh)
        dets = detections.boxes_xyxy[keep_det].astype(np.float64)
        scores = detections.box_scores[keep_det].astype(np.float64)

        predicted = [t.predict() for t in self._tracks]
        alive = [i for i, b in enumerate(predicted) if np.all(np.isfinite(b))]
        if len(alive) != len(self._tracks):
            self._tracks = [self._tracks[i] for i in alive]
            predicted = [predicted[i] for i in alive]
        trks = np.array(predicted, dtype=np.float64).reshape(-1, 4)
        velocities = np.array([t.velocity if t.velocity is not None else (0.0, 0.0) for t in self._tracks],
                              dtype=np.float64).reshape(-1, 2)
        has_dir = np.array([t.velocity is not None for t in self._tracks], dtype=bool)
        prev_obs = np.array([t.previous_observation(cfg.delta_t) for t in self._tracks],
                            dtype=np.float64).reshape(-1, 4)
        has_dir &= np.all(np.isfinite(prev_obs), axis=1)
        prev_obs = np.nan_to_num(prev_obs)

        first = associate_ocm(dets, scores, trks, prev_obs, velocities, has_dir, cfg.iou_threshold,
                              cfg.inertia)
        taken: dict[int, int] = {}  # track list index -> detection row (of dets)
        for d, t in first.matches:
            taken[int(t)] = int(d)
        um_d, um_t = first.unmatched_detections, first.unmatched_tracks
        if len(um_d) and len(um_t):  # OCR: leftovers against the last real observations
            last = np.array([self._tracks[t].last_observation for t in um_t], dtype=np.float64)
            ok = np.all(np.isfinite(last), axis=1)
            last = np.where(ok[:, None], last, 0.0)
            second = associate_iou(dets[um_d], last, cfg.iou_threshold)
            for d, t in second.matches:
                taken[int(um_t[t])] = int(um_d[d])
            um_d = um_d[second.unmatched_detections]
        for t_idx, d in taken.items():
            row = int(keep_det[d])
            self._tracks[t_idx].observe(self._observation(detections, row), cfg.delta_t)
        self.last_matched = frozenset(self._tracks[t].track_id for t in taken)

        for d in um_d:  # births
            row = int(keep_det[d])
            obs = self._observation(detections, row)
            # as in the published tracker, the birth box only initialises the filter: it is no
            # hit, no observation for OCM/OCR (keypoints ride along in the history all the same)
            track = Track(self._next_id, BoxKalmanFilter(obs.box_xyxy), deque([obs], maxlen=cfg.history))
            self._next_id += 1
            self._tracks.append(track)
            taken[len(self._tracks) - 1] = int(d)

        ids: list[int] = []
        rows: list[int] = []
        for t_idx, track in enumerate(self._tracks):
            if track.time_since_update < 1 and (
                track.hit_streak >= cfg.min_hits or self.frame_count <= cfg.min_hits
            ):
                ids.append(track.track_id)
                rows.append(int(keep_det[taken[t_idx]]))
        self._tracks = [t for t in self._tracks if t.time_since_update <= cfg.max_age]
        order = np.argsort(ids, kind="stable")
        return TrackedView(detections, np.asarray(ids, np.int64)[order], np.asarray(rows, np.int64)[order])

    @staticmethod
    def _observation(det: ViewDetections, row: int) -> Observation:
        return Observation(
            det.frame_index,
            det.boxes_xyxy[row].astype(np.float64),
            float(det.box_scores[row]),
            det.keypoints_xy[row].copy(),
            det.keypoint_scores[row].copy(),
        )


class MultiViewTracker:
    """One OC-SORT per camera."""

    def __init__(self, cameras: Sequence[str], config: OCSortConfig | None = None) -> None:
        if len(set(cameras)) != len(cameras) or not cameras:
            raise ValueError(f"need unique, non-empty camera names, got {list(cameras)}")
        self.config = config or OCSortConfig()
        self.trackers: dict[str, OCSort] = {c: OCSort(self.config, c) for c in cameras}

    @property
    def cameras(self) -> tuple[str, ...]:
        return tuple(self.trackers)

    def update(self, views: Sequence[ViewDetections]) -> tuple[TrackedView, ...]:
        """One multi-view frame: every camera's detections, in any order; results in camera order."""
        by_cam = {v.camera: v for v in views}
        unknown = sorted(set(by_cam) - set(self.trackers))
        if unknown or len(by_cam) != len(views):
            raise ValueError(f"views must be one per known camera {list(self.trackers)}, got "
                             f"{[v.camera for v in views]}")
        out = []
        for cam, tracker in self.trackers.items():
            view = by_cam.get(cam)
            if view is None:
                continue
            out.append(tracker.update(view))
        return tuple(out)
