"""A small hand-built test scene: four calibrated cameras in the CAVE's upper corners and
standing COCO skeletons, projected with lens distortion and pixel noise (real geometry, no mocks)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from pipeline.camera import Camera, intrinsics, look_at, project
from pipeline.pose.types import ViewDetections
from pipeline.skeleton import NUM_JOINTS
from pipeline.tracking.types import TrackedView

F64 = NDArray[np.float64]

# Standing skeleton in the body frame: x to the person's right, y forward, z up (metres).
STANDING = np.array([
    [0.00, 0.09, 1.62],   # nose
    [-0.03, 0.07, 1.66],  # l_eye
    [0.03, 0.07, 1.66],   # r_eye
    [-0.07, 0.00, 1.64],  # l_ear
    [0.07, 0.00, 1.64],   # r_ear
    [-0.19, 0.00, 1.42],  # l_shoulder
    [0.19, 0.00, 1.42],   # r_shoulder
    [-0.23, 0.02, 1.13],  # l_elbow
    [0.23, 0.02, 1.13],   # r_elbow
    [-0.25, 0.08, 0.88],  # l_wrist
    [0.25, 0.08, 0.88],   # r_wrist
    [-0.10, 0.00, 0.95],  # l_hip
    [0.10, 0.00, 0.95],   # r_hip
    [-0.11, 0.03, 0.51],  # l_knee
    [0.11, 0.03, 0.51],   # r_knee
    [-0.11, 0.00, 0.08],  # l_ankle
    [0.11, 0.00, 0.08],   # r_ankle
])
IMAGE_SIZE = (1920, 1080)


def skeleton_at(x: float, y: float, yaw_deg: float = 0.0, scale: float = 1.0) -> F64:
    """(17, 3) standing skeleton with its pelvis over (x, y), facing yaw_deg (0 = +Y, CCW)."""
    a = np.deg2rad(yaw_deg)
    rot = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    out: F64 = (STANDING * scale) @ rot.T + np.array([x, y, 0.0])
    return out


def corner_cameras(half_size_m: float = 1.5, height_m: float = 2.4) -> list[Camera]:
    """Four 1920x1080 cameras high in the corners, looking at the middle of the CAVE, with distortion."""
    cams = []
    corners = [(1, 1), (-1, 1), (-1, -1), (1, -1)]
    for i, (sx, sy) in enumerate(corners):
        R, t = look_at(np.array([sx * half_size_m, sy * half_size_m, height_m]), np.array([0.0, 0.0, 0.9]))
        dist = np.array([-0.08 + 0.01 * i, 0.03, 0.001, -0.001, 0.0])
        cams.append(Camera(f"cam0{i + 1}", IMAGE_SIZE, intrinsics(1050.0 + 10 * i, 1050.0 + 10 * i, 960, 540),
                           dist, R, t))
    return cams


def observe(
    cameras: Sequence[Camera],
    people: Sequence[F64],
    rng: np.random.Generator,
    noise_px: float = 1.5,
    track_ids: Sequence[Sequence[int]] | None = None,
    shuffle: bool = False,
    frame_index: int = 0,
    timestamp_s: float = 0.0,
) -> list[TrackedView]:
    """Project each person into each camera as a tracked view (score 0.9, noise in pixels).

    track_ids[c][p]: the track id of person p in camera c (default p + 1); shuffle: permute
    the order of people differently in each view. A person outside an image gets no detection.
    """
    views = []
    for c, cam in enumerate(cameras):
        kps, scores, boxes, tids = [], [], [], []
        order = rng.permutation(len(people)) if shuffle else np.arange(len(people))
        for p in order:
            uv = project(cam, people[p]) + rng.normal(0.0, noise_px, (NUM_JOINTS, 2))
            inside = np.all(np.isfinite(uv), axis=1) & (uv[:, 0] >= 0) & (uv[:, 0] < IMAGE_SIZE[0]) \
                & (uv[:, 1] >= 0) & (uv[:, 1] < IMAGE_SIZE[1])
            if inside.sum() < 5:
                continue
            kps.append(np.where(inside[:, None], uv, np.nan))
            scores.append(np.where(inside, 0.9, 0.0))
            lo, hi = np.nanmin(uv[inside], axis=0), np.nanmax(uv[inside], axis=0)
            boxes.append(np.concatenate([lo, hi]))
            tids.append(track_ids[c][p] if track_ids is not None else p + 1)
        n = len(kps)
        det = ViewDetections(
            cam.name, frame_index, timestamp_s, IMAGE_SIZE,
            np.asarray(boxes, np.float32).reshape(n, 4), np.full(n, 0.9, np.float32),
            np.asarray(kps, np.float32).reshape(n, NUM_JOINTS, 2),
            np.asarray(scores, np.float32).reshape(n, NUM_JOINTS),
        )
        views.append(TrackedView(det, np.asarray(tids, np.int64), np.arange(n, dtype=np.int64)))
    return views
