"""Building blocks of a programme: a person's resting posture, smooth profiles, a frame builder."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.gait.kinematics import NCH, Ch
from pipeline.sim.gait.support import Programme

F64 = NDArray[np.float64]
DEG = np.pi / 180.0


@dataclass(frozen=True, slots=True)
class Style:
    """A person's habits (radians): how they stand and carry their arms."""

    toe_out: float
    stance_abd: float
    knee_rest: float
    arm_abd: float
    elbow_rest: float
    trunk_rest: float
    head_rest: float
    arm_swing: float  # gain of the walking arm swing (1 = the published mean)


def sample_style(rng: np.random.Generator) -> Style:
    return Style(
        toe_out=rng.uniform(0, 12) * DEG,
        stance_abd=rng.uniform(-1, 4) * DEG,
        knee_rest=rng.uniform(0, 7) * DEG,
        arm_abd=rng.uniform(3, 12) * DEG,
        elbow_rest=rng.uniform(5, 25) * DEG,
        trunk_rest=rng.uniform(-3, 6) * DEG,
        head_rest=rng.uniform(-6, 10) * DEG,
        arm_swing=rng.uniform(0.4, 1.5),
    )


def neutral(style: Style, yaw: float) -> F64:
    """The resting standing pose facing ``yaw`` (both feet flat, toes turned out)."""
    row = np.zeros(NCH)
    row[Ch.YAW] = yaw
    row[Ch.FOOT_YAW_L] = yaw + style.toe_out
    row[Ch.FOOT_YAW_R] = yaw - style.toe_out
    for side in (0, 1):
        row[Ch.HIP_ABD_L + side] = style.stance_abd
        row[Ch.HIP_FLEX_L + side] = 0.4 * style.knee_rest
        row[Ch.KNEE_L + side] = style.knee_rest
        row[Ch.ANKLE_L + side] = flat_ankle(0.4 * style.knee_rest, style.knee_rest)
        row[Ch.SHOULDER_ABD_L + side] = style.arm_abd
        row[Ch.ELBOW_L + side] = style.elbow_rest
    row[Ch.TRUNK_LEAN] = style.trunk_rest
    row[Ch.HEAD_PITCH] = style.head_rest
    return row


def flat_ankle(hip_flex: F64 | float, knee: F64 | float, pitch: F64 | float = 0.0) -> F64:
    """The ankle angle that gives the foot ``pitch`` (0 = flat) for the leg's hip and knee."""
    return np.asarray(pitch - np.asarray(hip_flex) + np.asarray(knee))


def min_jerk(s: F64) -> F64:
    """0 -> 1 with zero velocity and acceleration at both ends (Flash & Hogan 1985)."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s * s)


def bump(n: int, peak: float = 0.5) -> F64:
    """0 -> 1 -> 0 over ``n`` samples (interior), peaking at fraction ``peak``."""
    s = (np.arange(n) + 0.5) / n
    up = min_jerk(s / peak)
    down = 1.0 - min_jerk((s - peak) / (1.0 - peak))
    return np.where(s < peak, up, down)


def ramp(n: int) -> F64:
    """0 -> 1 over ``n`` samples, the last sample reaching 1."""
    return min_jerk((np.arange(n) + 1) / n)


class Track:
    """Frames of a programme, appended block by block (a builder used by the behaviours)."""

    def __init__(self, fps: float, start: F64) -> None:
        self.fps = fps
        self._angles: list[F64] = []
        self._contact: list[NDArray[np.bool_]] = []
        self._slide: list[NDArray[np.bool_]] = []
        self._home: list[NDArray[np.bool_]] = []
        self.labels: list[str] = []
        self.tags: list[str] = []
        self._start = np.asarray(start, dtype=float).copy()

    def __len__(self) -> int:
        return len(self.labels)

    def frames(self, seconds: float) -> int:
        return max(1, round(seconds * self.fps))

    @property
    def last(self) -> F64:
        return self._angles[-1][-1].copy() if self._angles else self._start.copy()

    @property
    def last_contact(self) -> NDArray[np.bool_]:
        return self._contact[-1][-1].copy() if self._contact else np.array([True, True])

    def add(
        self,
        angles: F64,
        contact: NDArray[np.bool_] | tuple[bool, bool] = (True, True),
        slide: NDArray[np.bool_] | tuple[bool, bool] = (False, False),
        label: str = "still",
        tag: str = "",
        home: bool = False,
    ) -> None:
        """Append frames; ``home``: the feet lifted in them land back on their footprints."""
        n = angles.shape[0]
        self._angles.append(np.asarray(angles, dtype=float))
        self._contact.append(np.broadcast_to(np.asarray(contact, dtype=bool), (n, 2)).copy())
        self._slide.append(np.broadcast_to(np.asarray(slide, dtype=bool), (n, 2)).copy())
        self._home.append(~self._contact[-1] if home else np.zeros((n, 2), bool))
        self.labels.extend([label] * n)
        self.tags.extend([tag] * n)

    def ease(self, target: F64, seconds: float, tag: str = "", label: str = "still") -> None:
        """Move every channel from the last pose to ``target`` (both feet down)."""
        n = self.frames(seconds)
        start = self.last
        s = ramp(n)[:, None]
        self.add(start + (target - start) * s, label=label, tag=tag)

    def hold(self, seconds: float, tag: str = "", label: str = "still") -> None:
        n = self.frames(seconds)
        self.add(np.repeat(self.last[None], n, 0), label=label, tag=tag)

    def label_bout(self, first: int, action: str, tag: str) -> None:
        """Label frames from ``first`` on with ``action`` and ``tag`` from the first lift-off (or
        slide start) to the touch-down of the last step (TEAM.md LABELS); the rest stay as added."""
        contact = np.concatenate(self._contact)[first:]
        slide = np.concatenate(self._slide)[first:]
        moving = np.flatnonzero((~contact | slide).any(axis=1))
        if moving.size:
            a, b = first + moving[0], min(len(self.labels), first + moving[-1] + 2)
            for i in range(a, b):
                self.labels[i] = action
                self.tags[i] = tag

    def build(self) -> Programme:
        return Programme(
            np.concatenate(self._angles), np.concatenate(self._contact), np.concatenate(self._slide),
            np.concatenate(self._home), tuple(self.labels), tuple(self.tags),
        )
