"""What the pose stage hands on: the people found in one camera image.

The real detector (YOLO-pose on ONNX Runtime) and the simulator's virtual cameras
both produce :class:`ViewDetections`, so no later stage can tell them apart.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import NUM_JOINTS

F32 = NDArray[np.float32]
Region = tuple[float, float, float, float]  # [x1, y1, x2, y2] in image pixels


class Job(NamedTuple):
    """One slot of a detector batch: image ``image`` (its index), the ``region`` of it that goes
    in (None: the whole image), at network size ``net_size`` (w, h; None: the full-frame size)."""

    image: int
    region: Region | None = None
    net_size: tuple[int, int] | None = None


def _check(name: str, arr: np.ndarray, shape: tuple[int | None, ...], camera: str) -> None:
    if arr.ndim != len(shape) or any(s is not None and a != s for a, s in zip(arr.shape, shape, strict=True)):
        raise ValueError(f"{camera}: {name} must have shape {shape} (None = any), got {arr.shape}")


@dataclass(frozen=True, slots=True)
class ViewDetections:
    """People detected in one image of one camera.

    camera: camera name.
    frame_index: index of the multi-view frame this image belongs to.
    timestamp_s: capture time, seconds (monotonic clock of the capturing machine).
    image_size: (width, height) of the image, pixels.
    boxes_xyxy: (P, 4) float32 person boxes [x1, y1, x2, y2], pixels.
    box_scores: (P,) float32 detection confidence in [0, 1].
    keypoints_xy: (P, 17, 2) float32 COCO keypoints, pixels (NaN where not output).
    keypoint_scores: (P, 17) float32 keypoint confidence in [0, 1] (0 where not visible).
    """

    camera: str
    frame_index: int
    timestamp_s: float
    image_size: tuple[int, int]
    boxes_xyxy: F32
    box_scores: F32
    keypoints_xy: F32
    keypoint_scores: F32

    def __post_init__(self) -> None:
        for name in ("boxes_xyxy", "box_scores", "keypoints_xy", "keypoint_scores"):
            object.__setattr__(self, name, np.asarray(getattr(self, name), dtype=np.float32))
        p = self.boxes_xyxy.shape[0] if self.boxes_xyxy.ndim == 2 else -1
        _check("boxes_xyxy", self.boxes_xyxy, (None, 4), self.camera)
        _check("box_scores", self.box_scores, (p,), self.camera)
        _check("keypoints_xy", self.keypoints_xy, (p, NUM_JOINTS, 2), self.camera)
        _check("keypoint_scores", self.keypoint_scores, (p, NUM_JOINTS), self.camera)

    def __len__(self) -> int:
        return int(self.boxes_xyxy.shape[0])

    @classmethod
    def empty(cls, camera: str, frame_index: int, timestamp_s: float,
              image_size: tuple[int, int]) -> ViewDetections:
        return cls(
            camera, frame_index, timestamp_s, image_size,
            np.zeros((0, 4), np.float32), np.zeros((0,), np.float32),
            np.zeros((0, NUM_JOINTS, 2), np.float32), np.zeros((0, NUM_JOINTS), np.float32),
        )
