"""Orientation detection: the user's facing direction ``yaw_deg`` from a 3D skeleton.

CAVE convention (SPEC.md): 0 = facing +Y (the front wall), counter-clockwise
positive seen from above (+Z up, +X right), range (-180, 180].

The body's facing direction is perpendicular to the person's left-to-right
vector: hips and shoulders each give one (see :func:`features.facing_vectors`).
When a whole side is unknown (both the left hip and the left shoulder occluded),
the head gives it: the nose lies in front of the ears (or eyes). When nothing is
known the smoother holds its last value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.recognition.features import facing_vector, yaw_from_vector
from pipeline.skeleton import NUM_JOINTS, J

_NOSE = J["nose"]
_EARS = (J["l_ear"], J["r_ear"])
_EYES = (J["l_eye"], J["r_eye"])
# Angle between the ear-to-nose direction and the face's forward axis: ears about 15 cm apart,
# the nose tip about 10.5 cm in front of the ear line.
_EAR_NOSE_DEG = math.degrees(math.atan2(0.075, 0.105))


def _unit(v: NDArray[np.float64]) -> NDArray[np.float64] | None:
    if not np.isfinite(v).all():
        return None
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-6 else None


def _turn(v: NDArray[np.float64], deg: float) -> NDArray[np.float64]:
    a = math.radians(deg)
    c, s = math.cos(a), math.sin(a)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def head_facing_vector(joints: NDArray[np.floating]) -> NDArray[np.float64]:
    """Horizontal facing direction (2,) of one skeleton from the head; NaN if it cannot be told.

    In order of preference: the nose in front of the mid-ear point; the eye pair's
    left-to-right vector turned like the hips'; one ear and the nose, the ear-to-nose
    direction turned by the typical angle between it and the face's forward axis.
    """
    arr = np.asarray(joints, dtype=np.float64)[:, :2]
    nose, l_ear, r_ear = arr[_NOSE], arr[_EARS[0]], arr[_EARS[1]]
    candidates = [
        _unit(nose - 0.5 * (l_ear + r_ear)),
        _unit(_turn(arr[_EYES[0]] - arr[_EYES[1]], -90.0)),
    ]
    ear_nose_l, ear_nose_r = _unit(nose - l_ear), _unit(nose - r_ear)
    # from the left ear the nose lies forward-right: turn counter-clockwise back to forward
    candidates.append(None if ear_nose_l is None else _turn(ear_nose_l, _EAR_NOSE_DEG))
    candidates.append(None if ear_nose_r is None else _turn(ear_nose_r, -_EAR_NOSE_DEG))
    for vec in candidates:
        if vec is not None:
            return vec
    return np.full(2, np.nan)


def raw_yaw_deg(joints: NDArray[np.floating]) -> float:
    """Facing yaw of one skeleton (17, 3) in degrees, or NaN when it cannot be told."""
    arr = np.asarray(joints, dtype=np.float64)
    if arr.shape != (NUM_JOINTS, 3):
        raise ValueError(f"joints must have shape (17, 3), got {arr.shape}")
    x, y = facing_vector(arr)
    if not (math.isfinite(x) and math.isfinite(y)):
        x, y = head_facing_vector(arr).tolist()
    if not (math.isfinite(x) and math.isfinite(y)) or math.sqrt(x * x + y * y) < 1e-9:
        return math.nan
    return float(yaw_from_vector(np.array((x, y))))


def wrap_deg(angle: NDArray[np.floating] | float) -> NDArray[np.float64]:
    """Wrap angles into (-180, 180]."""
    a = np.mod(np.asarray(angle, dtype=np.float64) + 180.0, 360.0) - 180.0
    return np.where(a <= -180.0, a + 360.0, a)


def angle_diff_deg(a: NDArray[np.floating] | float, b: NDArray[np.floating] | float) -> NDArray[np.float64]:
    """Signed smallest difference a - b in degrees, in (-180, 180]."""
    return wrap_deg(np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64))


@dataclass(slots=True)
class YawSmoother:
    """Exponential smoothing of the facing direction on the unit circle.

    ``alpha`` is the weight of a new measurement at ``rate_hz``; a measurement
    after a longer or shorter gap weighs ``1 - (1 - alpha) ** (dt * rate_hz)``, so
    the time constant does not depend on the input frame rate.
    """

    alpha: float = 0.3
    rate_hz: float = 30.0
    _vec: NDArray[np.float64] | None = field(default=None, init=False)
    _t: float | None = field(default=None, init=False)
    _yaw_deg: float = field(default=0.0, init=False)  # of _vec, kept: read more often than it changes

    def __post_init__(self) -> None:
        if not 0 < self.alpha <= 1:
            raise ValueError(f"alpha must be in (0, 1], got {self.alpha}")
        if self.rate_hz <= 0:
            raise ValueError(f"rate_hz must be positive, got {self.rate_hz}")

    def reset(self) -> None:
        self._vec = None
        self._t = None
        self._yaw_deg = 0.0

    @property
    def yaw_deg(self) -> float:
        """The smoothed yaw (0 before any measurement)."""
        return self._yaw_deg

    def update(self, yaw_deg: float, timestamp_s: float) -> float:
        """Add one measurement (NaN = none this frame) and return the smoothed yaw."""
        if math.isfinite(yaw_deg):
            a = math.radians(yaw_deg)
            meas = np.array([-math.sin(a), math.cos(a)])
            if self._vec is None or self._t is None:
                self._vec = meas
            else:
                dt = max(timestamp_s - self._t, 0.0)
                w = 1.0 - (1.0 - self.alpha) ** max(dt * self.rate_hz, 1e-3)
                vec = (1.0 - w) * self._vec + w * meas
                norm = float(np.linalg.norm(vec))
                self._vec = vec / norm if norm > 1e-9 else meas
            self._t = timestamp_s
            self._yaw_deg = float(yaw_from_vector(self._vec))
        return self.yaw_deg
