"""The constant-velocity Kalman filter of SORT / OC-SORT on boxes.

State ``[x, y, s, r, vx, vy, vs]``: box centre (px), area ``s`` (px²), aspect ``r = w / h``
(constant), and the velocities of x, y and s. Observations are ``[x, y, s, r]``.
The noise set-up is SORT's (shared by OC-SORT): large uncertainty on the unobserved
initial velocities, more measurement noise on area and aspect than on position.

OC-SORT's observation-centric re-update (ORU) lives here too: when a track is observed
again after a gap, the filter is rolled back to its state at the last observation and
re-run over a virtual trajectory interpolated between the two real observations, which
undoes the error the filter accumulated while it coasted.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

_F = np.eye(7)
_F[0, 4] = _F[1, 5] = _F[2, 6] = 1.0
_H = np.eye(4, 7)


def box_to_z(box_xyxy: F64) -> F64:
    """[x1, y1, x2, y2] -> observation [cx, cy, area, w / h]."""
    x1, y1, x2, y2 = (float(v) for v in box_xyxy[:4])
    w, h = x2 - x1, y2 - y1
    return np.array([x1 + w / 2.0, y1 + h / 2.0, w * h, w / (h + 1e-6)])


def z_to_box(z: F64) -> F64:
    """[cx, cy, area, w / h] (or a full state) -> [x1, y1, x2, y2]; NaN if area * aspect <= 0."""
    cx, cy, s, r = (float(v) for v in z[:4])
    if not s * r > 0:
        return np.full(4, np.nan)
    w = np.sqrt(s * r)
    h = s / w
    return np.array([cx - w / 2.0, cy - h / 2.0, cx + w / 2.0, cy + h / 2.0])


def box_xywh(box_xyxy: F64) -> F64:
    x1, y1, x2, y2 = (float(v) for v in box_xyxy[:4])
    return np.array([(x1 + x2) / 2.0, (y1 + y2) / 2.0, x2 - x1, y2 - y1])


def xywh_box(c: F64) -> F64:
    cx, cy, w, h = (float(v) for v in c)
    return np.array([cx - w / 2.0, cy - h / 2.0, cx + w / 2.0, cy + h / 2.0])


@dataclass(frozen=True, slots=True)
class KalmanSnapshot:
    """The filter's state at the last real observation (for ORU)."""

    x: F64
    P: F64
    box_xyxy: F64


class BoxKalmanFilter:
    """Kalman filter on one box track (SORT's model and noise)."""

    def __init__(self, box_xyxy: F64) -> None:
        self.x = np.zeros(7)
        self.x[:4] = box_to_z(box_xyxy)
        self.P = np.eye(7)
        self.P[4:, 4:] *= 1000.0  # unobservable initial velocities
        self.P *= 10.0
        self.Q = np.eye(7)
        self.Q[-1, -1] *= 0.01
        self.Q[4:, 4:] *= 0.01
        self.R = np.eye(4)
        self.R[2:, 2:] *= 10.0
        self._snapshot = KalmanSnapshot(self.x.copy(), self.P.copy(),
                                        np.asarray(box_xyxy, dtype=np.float64)[:4].copy())
        self._missed = 0  # predictions since the last real observation

    def predict(self) -> F64:
        """Advance one frame; returns the predicted box [x1, y1, x2, y2]."""
        if self.x[6] + self.x[2] <= 0:  # the area would turn negative
            self.x[6] = 0.0
        self.x = _F @ self.x
        self.P = _F @ self.P @ _F.T + self.Q
        self._missed += 1
        return z_to_box(self.x)

    def peek(self, steps: int = 1) -> F64:
        """The box ``steps`` frames ahead, without changing the filter."""
        x = self.x.copy()
        for _ in range(steps):
            if x[6] + x[2] <= 0:
                x[6] = 0.0
            x = _F @ x
        return z_to_box(x)

    def _correct(self, z: F64) -> None:
        y = z - _H @ self.x
        S = _H @ self.P @ _H.T + self.R
        K = np.linalg.solve(S, _H @ self.P).T  # P H^T S^-1, S symmetric
        self.x = self.x + K @ y
        I_KH = np.eye(7) - K @ _H
        self.P = I_KH @ self.P @ I_KH.T + K @ self.R @ K.T  # Joseph form, stays symmetric

    def update(self, box_xyxy: F64) -> None:
        """Correct with a real observation; after a gap, re-update along a virtual path (ORU)."""
        box = np.asarray(box_xyxy, dtype=np.float64)[:4]
        gap = self._missed
        snap = self._snapshot
        if snap is not None and gap > 1:
            # roll back to the last observation and re-run predict/update over the gap
            self.x, self.P = snap.x.copy(), snap.P.copy()
            a, b = box_xywh(snap.box_xyxy), box_xywh(box)
            for k in range(1, gap + 1):
                self.x = _F @ self.x if self.x[6] + self.x[2] > 0 else _F @ np.r_[self.x[:6], 0.0]
                self.P = _F @ self.P @ _F.T + self.Q
                self._correct(box_to_z(xywh_box(a + (b - a) * k / gap)))
        else:
            self._correct(box_to_z(box))
        self._missed = 0
        self._snapshot = KalmanSnapshot(self.x.copy(), self.P.copy(), box.copy())

    @property
    def box(self) -> F64:
        """The current state's box [x1, y1, x2, y2]."""
        return z_to_box(self.x)
