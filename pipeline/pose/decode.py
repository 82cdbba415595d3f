"""Decoding of the YOLO-pose output and non-maximum suppression (pure numpy).

The raw output of one image is (56, N): per anchor ``cx, cy, w, h, score`` followed by
17 x ``(x, y, conf)`` keypoints, all in network-input pixels, scores already sigmoid.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pipeline.skeleton import NUM_JOINTS

F32 = NDArray[np.float32]
Boxes = NDArray[np.floating[Any]]
OUTPUT_CHANNELS = 5 + 3 * NUM_JOINTS  # 56


@dataclass(frozen=True, slots=True)
class RawPoses:
    """People found in one network input, in network-input pixels.

    boxes_xyxy: (P, 4) float32. scores: (P,) float32.
    keypoints_xy: (P, 17, 2) float32. keypoint_scores: (P, 17) float32.
    """

    boxes_xyxy: F32
    scores: F32
    keypoints_xy: F32
    keypoint_scores: F32

    def __post_init__(self) -> None:
        p = self.boxes_xyxy.shape[0]
        if (self.boxes_xyxy.shape != (p, 4) or self.scores.shape != (p,)
                or self.keypoints_xy.shape != (p, NUM_JOINTS, 2)
                or self.keypoint_scores.shape != (p, NUM_JOINTS)):
            raise ValueError(
                f"inconsistent shapes: boxes {self.boxes_xyxy.shape}, scores {self.scores.shape}, "
                f"keypoints {self.keypoints_xy.shape}, keypoint scores {self.keypoint_scores.shape}"
            )

    def __len__(self) -> int:
        return int(self.boxes_xyxy.shape[0])

    def take(self, index: NDArray[np.intp]) -> RawPoses:
        return RawPoses(self.boxes_xyxy[index], self.scores[index],
                        self.keypoints_xy[index], self.keypoint_scores[index])


def iou_matrix(boxes_a: Boxes, boxes_b: Boxes) -> NDArray[np.float64]:
    """Pairwise IoU of boxes ``a`` (N, 4) and ``b`` (M, 4), xyxy -> (N, M)."""
    a = np.asarray(boxes_a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(boxes_b, dtype=np.float64).reshape(-1, 4)
    ix1 = np.maximum(a[:, None, 0], b[None, :, 0])
    iy1 = np.maximum(a[:, None, 1], b[None, :, 1])
    ix2 = np.minimum(a[:, None, 2], b[None, :, 2])
    iy2 = np.minimum(a[:, None, 3], b[None, :, 3])
    inter = np.clip(ix2 - ix1, 0, None) * np.clip(iy2 - iy1, 0, None)
    area_a = np.clip(a[:, 2] - a[:, 0], 0, None) * np.clip(a[:, 3] - a[:, 1], 0, None)
    area_b = np.clip(b[:, 2] - b[:, 0], 0, None) * np.clip(b[:, 3] - b[:, 1], 0, None)
    union = area_a[:, None] + area_b[None, :] - inter
    return np.where(union > 0, inter / np.maximum(union, 1e-12), 0.0)


def nms(boxes_xyxy: Boxes, scores: Boxes, iou_threshold: float, max_out: int = 0) -> NDArray[np.intp]:
    """Greedy non-maximum suppression; indices of the kept boxes, best score first.

    A box is dropped when its IoU with a better kept box is above ``iou_threshold``.
    """
    if not 0.0 <= iou_threshold <= 1.0:
        raise ValueError(f"iou_threshold must be in [0, 1], got {iou_threshold}")
    n = int(np.asarray(scores).shape[0])
    if n == 0:
        return np.zeros((0,), dtype=np.intp)
    order = np.argsort(-np.asarray(scores), kind="stable")
    iou = iou_matrix(boxes_xyxy[order], boxes_xyxy[order])
    suppressed = np.zeros(n, dtype=bool)
    keep: list[int] = []
    for i in range(n):
        if suppressed[i]:
            continue
        keep.append(i)
        if max_out and len(keep) >= max_out:
            break
        suppressed |= iou[i] > iou_threshold
    return order[np.asarray(keep, dtype=np.intp)]


def decode(output: F32, score_threshold: float, iou_threshold: float, max_people: int = 32) -> RawPoses:
    """One image's raw output (56, N) -> people above ``score_threshold`` after NMS."""
    if output.ndim != 2 or output.shape[0] != OUTPUT_CHANNELS:
        raise ValueError(f"pose output must be ({OUTPUT_CHANNELS}, N), got {output.shape}")
    scores = output[4]
    cand = np.flatnonzero(scores > score_threshold)
    if cand.size == 0:
        return RawPoses(np.zeros((0, 4), np.float32), np.zeros((0,), np.float32),
                        np.zeros((0, NUM_JOINTS, 2), np.float32), np.zeros((0, NUM_JOINTS), np.float32))
    sel = output[:, cand].T.astype(np.float32, copy=False)  # (C, 56)
    cx, cy, w, h = sel[:, 0], sel[:, 1], sel[:, 2], sel[:, 3]
    boxes = np.stack([cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2], axis=1)
    keep = nms(boxes, sel[:, 4], iou_threshold, max_out=max_people)
    sel = sel[keep]
    kp = sel[:, 5:].reshape(-1, NUM_JOINTS, 3)
    return RawPoses(
        np.ascontiguousarray(boxes[keep]),
        np.ascontiguousarray(sel[:, 4]),
        np.ascontiguousarray(kp[:, :, :2]),
        np.ascontiguousarray(kp[:, :, 2]),
    )
