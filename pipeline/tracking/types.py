"""What the tracking stage hands on: the people of one view with a stable per-view track id."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.pose.types import F32, ViewDetections


@dataclass(frozen=True, slots=True)
class TrackedView:
    """The tracks of one camera that were matched to a detection in this image.

    detections: the view's detections as the pose stage gave them.
    track_ids: (P,) int64, one per output person, stable over time within this camera.
    detection_index: (P,) int64, which row of ``detections`` each track took.
    Keypoints and boxes ride along: ``keypoints_xy[i]`` is the keypoints of ``track_ids[i]``.
    """

    detections: ViewDetections
    track_ids: NDArray[np.int64]
    detection_index: NDArray[np.int64]

    def __post_init__(self) -> None:
        ids = np.asarray(self.track_ids, dtype=np.int64).reshape(-1)
        idx = np.asarray(self.detection_index, dtype=np.int64).reshape(-1)
        if ids.shape != idx.shape:
            raise ValueError(f"track_ids {ids.shape} and detection_index {idx.shape} differ")
        if idx.size and (idx.min() < 0 or idx.max() >= len(self.detections)):
            raise ValueError(f"detection_index out of range for {len(self.detections)} detections")
        object.__setattr__(self, "track_ids", ids)
        object.__setattr__(self, "detection_index", idx)

    @property
    def camera(self) -> str:
        return self.detections.camera

    @property
    def boxes_xyxy(self) -> F32:
        return self.detections.boxes_xyxy[self.detection_index]

    @property
    def keypoints_xy(self) -> F32:
        return self.detections.keypoints_xy[self.detection_index]

    @property
    def keypoint_scores(self) -> F32:
        return self.detections.keypoint_scores[self.detection_index]

    def __len__(self) -> int:
        return int(self.track_ids.shape[0])
