"""A view's tracked people carried to a frame the pose model did not look at.

Each person the tracker matched in its last update (and has confirmed) is moved to the box its
motion model expects now (:meth:`BoxKalmanFilter.peek`, the filter is not advanced), and the
keypoints of their last detection go along, shifted and scaled with the box. (Moving each
keypoint on with its own velocity between the last two detections was tried: on the demo, with
two of four views per frame, the carried keypoints were 19.7 px (median) from those of the run
that detects every view, against 21.0 px with the box, but 50.8 against 42.5 px at the 90th
percentile and 104 against 77 px at worst: a swing extrapolated overshoots.) The box score is
lowered by ``decay`` per carried frame and the keypoint scores by ``keypoint_decay`` per frame
since the last detection: the triangulation weighs the fresh views most, and a person carried
for long drops below the tracker's and the triangulation's thresholds unless a detection
refreshes them. Fed to the tracker like detections, each one is matched to its own track: the
ids do not change. See :mod:`pipeline.pose.stagger`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.pose.types import ViewDetections
from pipeline.skeleton import NUM_JOINTS
from pipeline.tracking.ocsort import OCSort


@dataclass(frozen=True, slots=True)
class Seen:
    """One detection of a tracked person: frame, box, keypoints (17, 2), keypoint scores (17,)."""

    frame_index: int
    box_xyxy: NDArray[np.float64]
    keypoints_xy: NDArray[np.float32]
    keypoint_scores: NDArray[np.float32]


def carried_detections(tracker: OCSort, frame_index: int, timestamp_s: float, image_size: tuple[int, int],
                       decay: float, keypoint_decay: float,
                       seen: Mapping[int, Seen] | None = None) -> ViewDetections:
    """The tracked people of ``tracker``'s view carried to this frame; ``seen``: track id -> its
    last detection (see the module docstring)."""
    boxes, scores, kps, kp_scores = [], [], [], []
    need = max(tracker.config.min_hits, 1)
    w, h = image_size
    for track in tracker.tracks:
        if track.time_since_update > 0 or track.hits < need:
            continue
        to = track.kf.peek(1)
        last = track.last
        if not np.all(np.isfinite(to)) or not np.all(np.isfinite(last.box_xyxy)):
            continue
        tx1, ty1, tx2, ty2 = to
        box = np.array([np.clip(tx1, 0, w), np.clip(ty1, 0, h), np.clip(tx2, 0, w), np.clip(ty2, 0, h)],
                       np.float32)
        if box[2] - box[0] < 2 or box[3] - box[1] < 2:  # carried out of the image
            continue
        latest = seen.get(track.track_id) if seen is not None else None
        if latest is not None and latest.frame_index < frame_index:
            moved = _with_box(latest.keypoints_xy, latest.box_xyxy, to)
            since = frame_index - latest.frame_index
            kp_score = latest.keypoint_scores * np.float32(keypoint_decay**since)
        else:
            moved = _with_box(last.keypoints_xy, last.box_xyxy, to)
            kp_score = last.keypoint_scores * np.float32(keypoint_decay)
        boxes.append(box)
        scores.append(float(last.score) * decay)
        kps.append(moved)
        kp_scores.append(kp_score.astype(np.float32))
    if not boxes:
        return ViewDetections.empty(tracker.camera, frame_index, timestamp_s, image_size)
    return ViewDetections(tracker.camera, frame_index, timestamp_s, image_size, np.stack(boxes),
                          np.asarray(scores, np.float32), np.stack(kps), np.stack(kp_scores))


def _with_box(keypoints: NDArray[np.float32], from_box: NDArray[np.float64],
              to_box: NDArray[np.float64]) -> NDArray[np.float32]:
    """Keypoints moved with their box (shifted and scaled)."""
    fx1, fy1, fx2, fy2 = from_box
    tx1, ty1, tx2, ty2 = to_box
    out = np.empty((NUM_JOINTS, 2), np.float32)
    out[:, 0] = (keypoints[:, 0] - fx1) * ((tx2 - tx1) / max(fx2 - fx1, 1e-6)) + tx1
    out[:, 1] = (keypoints[:, 1] - fy1) * ((ty2 - ty1) / max(fy2 - fy1, 1e-6)) + ty1
    return out
