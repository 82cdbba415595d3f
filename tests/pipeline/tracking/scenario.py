"""Scripted people for tracker tests: boxes per frame -> ViewDetections with keypoints that
identify their person (keypoint scores = a per-person tag), in a shuffled row order."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pipeline.pose.types import ViewDetections
from pipeline.skeleton import NUM_JOINTS

IMAGE = (1920, 1080)


def box_at(cx: float, cy: float, w: float = 100.0, h: float = 300.0) -> tuple[float, float, float, float]:
    return cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2


def tag(person: int) -> float:
    """The keypoint score that marks a scripted person's keypoints."""
    return 0.5 + 0.01 * person


def frame(
    index: int,
    people: Sequence[tuple[int, tuple[float, float, float, float]]],
    rng: np.random.Generator | None = None,
    score: float = 0.9,
    camera: str = "cam01",
) -> ViewDetections:
    """people: (person number, box) visible in this frame; rows shuffled when ``rng`` is given."""
    order = list(range(len(people)))
    if rng is not None:
        rng.shuffle(order)
    boxes = np.array([people[k][1] for k in order], np.float32).reshape(-1, 4)
    kp = np.zeros((len(order), NUM_JOINTS, 2), np.float32)
    kp[:, :, 0] = ((boxes[:, 0] + boxes[:, 2]) / 2)[:, None]
    kp[:, :, 1] = np.linspace(boxes[:, 1], boxes[:, 3], NUM_JOINTS, axis=1)
    sc = np.array([[tag(people[k][0])] * NUM_JOINTS for k in order], np.float32).reshape(-1, NUM_JOINTS)
    return ViewDetections(camera, index, index / 60, IMAGE, boxes, np.full(len(order), score, np.float32),
                          kp, sc)
