"""Per-user head tracks: the pose of each frame, its linear and angular velocity, and the
short-horizon prediction that makes up for the pipeline's latency.

Velocities are finite differences of successive poses, low-passed at ``velocity_cutoff_hz`` and
``angular_cutoff_hz`` (first order, as the One-Euro filter's derivative); the prediction
extrapolates at constant velocity: ``p + v h`` and ``exp([w] h) R`` (w in the CAVE frame).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from pipeline.head.config import HeadConfig
from pipeline.head.pose import FACE_JOINTS, HeadFrame, head_pose_from_joints
from pipeline.triangulation.types import Person3D

F64 = NDArray[np.float64]


def _alpha(cutoff_hz: float, dt_s: float) -> float:
    tau = 1.0 / (2.0 * math.pi * cutoff_hz)
    return 1.0 / (1.0 + tau / dt_s)


def _vec(x: F64) -> tuple[float, float, float]:
    return (float(x[0]), float(x[1]), float(x[2]))


@dataclass(frozen=True, slots=True)
class HeadPose:
    """A head pose as streamed: for the time ``timestamp_s + predicted_ms``.

    timestamp_s: capture time of the camera frames it came from (``time.monotonic()`` seconds
        live, the frame time offline).
    position_m: (x, y, z) the point between the eyes, CAVE frame, metres.
    forward, up: unit vectors in the CAVE frame.
    predicted_ms: how far ahead of ``timestamp_s`` the pose was extrapolated (0 = none).
    """

    user_id: int
    position_m: tuple[float, float, float]
    forward: tuple[float, float, float]
    up: tuple[float, float, float]
    timestamp_s: float
    predicted_ms: float = 0.0

    def __post_init__(self) -> None:
        for name in ("position_m", "forward", "up"):
            if len(getattr(self, name)) != 3:
                raise ValueError(f"{name} must have 3 values, got {len(getattr(self, name))}")
        if not math.isfinite(self.predicted_ms) or self.predicted_ms < 0:
            raise ValueError(f"predicted_ms must be a finite number >= 0, got {self.predicted_ms!r}")


@dataclass(frozen=True, slots=True)
class HeadEstimate:
    """One user's head at the capture time of a frame, with its velocities (for prediction).

    position_m: (3,) metres; rotation: (3, 3) head-to-CAVE (columns right, forward, up);
    velocity_mps: (3,); angular_velocity_rps: (3,) rad/s about the CAVE axes.
    """

    user_id: int
    timestamp_s: float
    position_m: F64
    rotation: F64
    velocity_mps: F64
    angular_velocity_rps: F64
    method: str = "face"

    def predict(self, horizon_s: float) -> HeadPose:
        """The pose ``horizon_s`` after the capture time, at constant velocity (0 = as measured)."""
        h = max(float(horizon_s), 0.0)
        p = self.position_m + self.velocity_mps * h
        rot = (
            Rotation.from_rotvec(self.angular_velocity_rps * h).as_matrix() @ self.rotation
            if h > 0
            else self.rotation
        )
        return HeadPose(
            self.user_id, _vec(p), _vec(rot[:, 1]), _vec(rot[:, 2]), self.timestamp_s, round(h * 1000.0, 3)
        )


_SCALE_SAMPLES = 60  # face fits with all five keypoints whose sizes give a person's head size
_MIN_SCALE_SAMPLES = 10
_SCALE_RANGE = (0.8, 1.25)


@dataclass(slots=True)
class _Track:
    t_s: float
    position_m: F64
    rotation: F64
    velocity_mps: F64
    angular_velocity_rps: F64


class HeadTracker:
    """Head estimates of the tracked users, frame by frame (state per user id)."""

    def __init__(self, config: HeadConfig | None = None) -> None:
        self.config = config or HeadConfig()
        self._tracks: dict[int, _Track] = {}
        self._scales: dict[int, list[float]] = {}  # per user id, kept while the user is tracked

    def reset(self) -> None:
        self._tracks.clear()
        self._scales.clear()

    def scale(self, user_id: int) -> float:
        """The head size of this user relative to the template (1 until enough full-face fits)."""
        samples = self._scales.get(user_id, [])
        if len(samples) < _MIN_SCALE_SAMPLES:
            return 1.0
        return float(np.clip(np.median(samples), *_SCALE_RANGE))

    def _learn_scale(self, person: Person3D) -> None:
        samples = self._scales.setdefault(person.user_id, [])
        if len(samples) >= _SCALE_SAMPLES or not np.all(person.joint_valid[list(FACE_JOINTS)]):
            return
        fit = head_pose_from_joints(person.joints_m, person.joint_valid, 5, scale=None)
        if fit is not None and fit.method == "face":
            samples.append(fit.scale)

    def _step(self, tr: _Track | None, frame: HeadFrame, t: float) -> _Track:
        cfg = self.config
        if tr is None or not 0.0 < t - tr.t_s <= cfg.reset_s:
            return _Track(t, frame.position_m.copy(), frame.rotation.copy(), np.zeros(3), np.zeros(3))
        dt = t - tr.t_s
        p, rot = frame.position_m, frame.rotation
        if cfg.smoothing_cutoff_hz > 0:
            a = _alpha(cfg.smoothing_cutoff_hz, dt)
            p = tr.position_m + a * (p - tr.position_m)
            rel = Rotation.from_matrix(tr.rotation.T @ rot).as_rotvec()
            rot = tr.rotation @ Rotation.from_rotvec(a * rel).as_matrix()
        av = _alpha(cfg.velocity_cutoff_hz, dt)
        v_raw = (p - tr.position_m) / dt
        w = np.zeros(3)
        if cfg.angular_cutoff_hz > 0:
            aw = _alpha(cfg.angular_cutoff_hz, dt)
            w_raw = Rotation.from_matrix(rot @ tr.rotation.T).as_rotvec() / dt
            w = tr.angular_velocity_rps + aw * (w_raw - tr.angular_velocity_rps)
        return _Track(
            t,
            np.asarray(p, dtype=np.float64).copy(),
            np.asarray(rot, dtype=np.float64).copy(),
            tr.velocity_mps + av * (v_raw - tr.velocity_mps),
            w,
        )

    def update(
        self, people: Sequence[Person3D], timestamp_s: float, users: Iterable[int] | None = None
    ) -> tuple[HeadEstimate, ...]:
        """One frame's people (the ``users`` among them; None = all) -> their head estimates,
        sorted by user id. A person whose head cannot be estimated this frame is left out (their
        track waits ``reset_s``); users no longer tracked are forgotten."""
        t = float(timestamp_s)
        wanted = None if users is None else set(users)
        out: list[HeadEstimate] = []
        for p in sorted(people, key=lambda q: q.user_id):
            if wanted is not None and p.user_id not in wanted:
                continue
            self._learn_scale(p)
            prev = self._tracks.get(p.user_id)
            prior = prev.rotation if prev is not None and 0.0 < t - prev.t_s <= self.config.reset_s else None
            frame = head_pose_from_joints(
                p.joints_m, p.joint_valid, self.config.min_face_joints, self.scale(p.user_id), prior
            )
            if frame is None:
                continue
            tr = self._step(prev, frame, t)
            self._tracks[p.user_id] = tr
            out.append(
                HeadEstimate(
                    p.user_id,
                    t,
                    tr.position_m,
                    tr.rotation,
                    tr.velocity_mps,
                    tr.angular_velocity_rps,
                    frame.method,
                )
            )
        for uid in [u for u, tr in self._tracks.items() if t - tr.t_s > self.config.reset_s]:
            del self._tracks[uid]
        present = {p.user_id for p in people}
        for uid in [u for u in self._scales if u not in present and u not in self._tracks]:
            del self._scales[uid]
        return tuple(out)
