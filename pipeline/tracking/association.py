"""Association of detections to tracks for OC-SORT (pure functions).

First round: IoU between detections and the tracks' predicted boxes plus the
observation-centric momentum term (OCM): how well the direction from a track's
observation ``delta_t`` frames back to the detection agrees with the track's observed
direction of motion, weighted by ``inertia`` and the detection score. Second round
(observation-centric recovery, OCR): IoU between the leftovers and the tracks' last
real observations. Both rounds solve the assignment with the Hungarian method.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import linear_sum_assignment

from pipeline.pose.decode import iou_matrix

F64 = NDArray[np.float64]
Idx = NDArray[np.int64]


@dataclass(frozen=True, slots=True)
class Assignment:
    """matches: (M, 2) int64 rows [detection, track]; the rest unmatched (sorted)."""

    matches: Idx
    unmatched_detections: Idx
    unmatched_tracks: Idx


def centre(boxes: F64) -> F64:
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return np.stack([(b[:, 0] + b[:, 2]) / 2.0, (b[:, 1] + b[:, 3]) / 2.0], axis=1)


def unit_direction(from_boxes: F64, to_boxes: F64) -> F64:
    """Unit vectors (dy, dx) from the centres of ``from_boxes`` to those of ``to_boxes`` (row-wise)."""
    d = centre(to_boxes) - centre(from_boxes)
    norm = np.sqrt((d**2).sum(axis=1, keepdims=True)) + 1e-6
    return (d / norm)[:, ::-1]


def direction_consistency(
    detections: F64, previous_obs: F64, velocities: F64, valid: NDArray[np.bool_]
) -> F64:
    """OCM term (D, T) in [-0.5, 0.5]: (pi/2 - angle between the track's direction and the
    direction previous observation -> detection) / pi; 0 for tracks without a direction."""
    det_c = centre(detections)  # (D, 2) x, y
    obs_c = centre(previous_obs)  # (T, 2)
    d = det_c[:, None, :] - obs_c[None, :, :]  # (D, T, 2)
    norm = np.sqrt((d**2).sum(axis=2)) + 1e-6
    dx, dy = d[..., 0] / norm, d[..., 1] / norm
    cos = np.clip(velocities[None, :, 1] * dx + velocities[None, :, 0] * dy, -1.0, 1.0)
    term = (np.pi / 2.0 - np.abs(np.arccos(cos))) / np.pi
    return term * valid[None, :].astype(np.float64)


def _hungarian(score: F64) -> Idx:
    """Maximise total ``score``; (K, 2) [row, col] pairs."""
    rows, cols = linear_sum_assignment(-score)
    return np.stack([rows, cols], axis=1).astype(np.int64)


def _unused(n: int, used: Idx) -> Idx:
    """0..n-1 without ``used``, sorted (np.setdiff1d costs ten times more on these few items)."""
    keep = np.ones(n, dtype=bool)
    keep[used] = False
    return np.flatnonzero(keep).astype(np.int64)


def _split(pairs: Idx, iou: F64, threshold: float, n_det: int, n_trk: int) -> Assignment:
    ok = iou[pairs[:, 0], pairs[:, 1]] >= threshold if len(pairs) else np.zeros(0, bool)
    matches = (pairs[ok] if len(pairs) else np.zeros((0, 2), np.int64)).astype(np.int64).reshape(-1, 2)
    return Assignment(matches, _unused(n_det, matches[:, 0]), _unused(n_trk, matches[:, 1]))


def associate_ocm(
    detections: F64,
    scores: F64,
    predicted: F64,
    previous_obs: F64,
    velocities: F64,
    has_direction: NDArray[np.bool_],
    iou_threshold: float,
    inertia: float,
) -> Assignment:
    """First OC-SORT round: IoU with predicted boxes + ``inertia`` x score x OCM term.

    detections (D, 4), scores (D,), predicted (T, 4), previous_obs (T, 4) each track's
    observation ``delta_t`` frames back, velocities (T, 2) unit (dy, dx), has_direction (T,).
    A pair is kept only if its IoU reaches ``iou_threshold``.
    """
    n_det, n_trk = len(detections), len(predicted)
    if n_det == 0 or n_trk == 0:
        return _split(np.zeros((0, 2), np.int64), np.zeros((n_det, n_trk)), iou_threshold, n_det, n_trk)
    iou = iou_matrix(detections, predicted)
    above = iou > iou_threshold
    if above.sum(axis=1).max() == 1 and above.sum(axis=0).max() == 1:
        pairs = np.argwhere(above).astype(np.int64)  # unambiguous: no assignment needed
    else:
        angle = direction_consistency(detections, previous_obs, velocities, has_direction)
        pairs = _hungarian(iou + inertia * angle * np.asarray(scores, np.float64)[:, None])
    return _split(pairs, iou, iou_threshold, n_det, n_trk)


def associate_iou(detections: F64, boxes: F64, iou_threshold: float) -> Assignment:
    """Plain IoU round (OCR uses it with the tracks' last observations)."""
    n_det, n_trk = len(detections), len(boxes)
    if n_det == 0 or n_trk == 0:
        return _split(np.zeros((0, 2), np.int64), np.zeros((n_det, n_trk)), iou_threshold, n_det, n_trk)
    iou = iou_matrix(detections, boxes)
    if iou.max() <= iou_threshold:
        return _split(np.zeros((0, 2), np.int64), iou, iou_threshold, n_det, n_trk)
    return _split(_hungarian(iou), iou, iou_threshold, n_det, n_trk)
