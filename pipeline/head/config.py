"""The head stage's frozen config: the settings' ``[head]`` section (no heavy imports here)."""

from __future__ import annotations

from dataclasses import dataclass


def _check(cond: bool, what: str, value: object) -> None:
    if not cond:
        raise ValueError(f"{what}, got {value!r}")


@dataclass(frozen=True, slots=True)
class HeadConfig:
    """Head pose of the navigators, streamed as protocol-v1 ``head`` messages.

    enabled: compute and stream head poses at all.
    horizon_ms: how far ahead each message is predicted. None (the default) = the pipeline's
        measured latency: the age of the camera frames when the message is sent (capture to
        send, measured per message) plus ``display_ms``; a number = that fixed horizon; 0 = no
        prediction (the pose of the capture time).
    display_ms: added to the measured latency: the workstations' own delay (network, render,
        display scan-out), which the pipeline cannot measure.
    max_horizon_ms: the horizon is never longer than this (extrapolation grows the error).
    velocity_cutoff_hz: low-pass cut-off of the linear velocity estimate.
    angular_cutoff_hz: low-pass cut-off of the angular velocity estimate; 0 (the default) = the
        rotation is not extrapolated, only the position: on the simulator's tuning seeds every
        cut-off from 0.3 to 2 Hz made the predicted rotation worse than the measured one (the
        face's rotation is noisier than its position, and heads turn less steadily than they move).
    smoothing_cutoff_hz: low-pass cut-off of the pose itself (0 = the skeleton's own smoothing
        only).
    min_face_joints: face keypoints (nose, eyes, ears) needed for a pose from the face alone;
        with fewer, the shoulders give the yaw and the face points the position.
    reset_s: a user whose head was unseen this long starts afresh (velocities zero).
    """

    enabled: bool = True
    horizon_ms: float | None = None
    display_ms: float = 0.0
    max_horizon_ms: float = 150.0
    velocity_cutoff_hz: float = 3.0
    angular_cutoff_hz: float = 0.0
    smoothing_cutoff_hz: float = 0.0
    min_face_joints: int = 3
    reset_s: float = 0.5

    def __post_init__(self) -> None:
        _check(
            self.horizon_ms is None or 0.0 <= self.horizon_ms <= 1000.0,
            "horizon_ms must be null or in [0, 1000]",
            self.horizon_ms,
        )
        _check(0.0 <= self.display_ms <= 500.0, "display_ms must be in [0, 500]", self.display_ms)
        _check(
            0.0 <= self.max_horizon_ms <= 1000.0, "max_horizon_ms must be in [0, 1000]", self.max_horizon_ms
        )
        _check(self.velocity_cutoff_hz > 0.0, "velocity_cutoff_hz must be > 0", self.velocity_cutoff_hz)
        _check(self.angular_cutoff_hz >= 0.0, "angular_cutoff_hz must be >= 0", self.angular_cutoff_hz)
        _check(self.smoothing_cutoff_hz >= 0.0, "smoothing_cutoff_hz must be >= 0", self.smoothing_cutoff_hz)
        _check(3 <= self.min_face_joints <= 5, "min_face_joints must be in [3, 5]", self.min_face_joints)
        _check(self.reset_s > 0.0, "reset_s must be > 0", self.reset_s)

    def horizon_s(self, age_s: float) -> float:
        """The prediction horizon for a pose whose frames are ``age_s`` old when sent."""
        ms = (max(age_s, 0.0) * 1000.0 + self.display_ms) if self.horizon_ms is None else self.horizon_ms
        return min(ms, self.max_horizon_ms) / 1000.0
