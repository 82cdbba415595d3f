"""The tracking stage's frozen config: the settings' ``[tracking]`` section (no heavy imports here;
the tracker itself is :mod:`pipeline.tracking.ocsort`)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class OCSortConfig:
    """OC-SORT parameters (the published defaults).

    det_thresh: detections below this score neither match nor start tracks.
    max_age: frames a track survives without a detection.
    min_hits: consecutive matches before a track is reported (not in the first min_hits frames).
    iou_threshold: minimum IoU for a match, both rounds.
    delta_t: frames between the two observations that give a track's direction (OCM).
    inertia: weight of the direction-consistency term (OCM).
    history: how many recent observations (box + keypoints) a track keeps.
    """

    det_thresh: float = 0.3
    max_age: int = 30
    min_hits: int = 3
    iou_threshold: float = 0.3
    delta_t: int = 3
    inertia: float = 0.2
    history: int = 30

    def __post_init__(self) -> None:
        if not 0.0 <= self.det_thresh <= 1.0 or not 0.0 <= self.iou_threshold <= 1.0:
            raise ValueError(f"det_thresh and iou_threshold must be in [0, 1], got "
                             f"{self.det_thresh}, {self.iou_threshold}")
        if self.max_age < 1 or self.min_hits < 0 or self.delta_t < 1 or self.history < 1:
            raise ValueError(
                f"need max_age >= 1, min_hits >= 0, delta_t >= 1, history >= 1; got {self.max_age}, "
                f"{self.min_hits}, {self.delta_t}, {self.history}"
            )
        if self.inertia < 0:
            raise ValueError(f"inertia must be >= 0, got {self.inertia}")
