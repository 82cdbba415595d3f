"""The plan of one simulated routine: per-frame control channels and the planners' shared context.

The planners (:mod:`pipeline.sim.stepping` for stepping bouts and turns,
:mod:`pipeline.sim.behaviours` for still behaviours) write into :class:`Channels` and plan foot
moves on :class:`pipeline.sim.feet.Feet`; :mod:`pipeline.sim.motion` then poses the skeleton from
them. Body-frame offsets: x to the person's right, y forward, z up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.body import BodyParams, MotionStyle
from pipeline.sim.feet import SIDE_SIGN, Feet, right_xy

F64 = NDArray[np.float64]

ARM_FRAMES = ("trunk", "body", "head", "hip", "knee")


@dataclass(frozen=True, slots=True)
class ArmPose:
    """A hand target blended over the arm's own pose with weight ``weight`` (T,).

    side: -1 left arm, +1 right arm. target: (T, 3) or (3,) offset in ``frame``:
    ``trunk`` from the shoulder in the trunk frame, ``body`` from the support point on the floor
    in the facing frame (a spot on the floor), ``head`` from the head centre in the head frame,
    ``hip`` from the hip in the pelvis frame, ``knee`` from the knee in the facing frame.
    pole: (3,) elbow bend direction in the trunk frame.
    """

    side: int
    weight: F64
    target: F64
    frame: str
    pole: tuple[float, float, float]

    def __post_init__(self) -> None:
        if self.frame not in ARM_FRAMES:
            raise ValueError(f"arm frame must be one of {ARM_FRAMES}, got {self.frame!r}")


@dataclass(slots=True)
class Channels:
    """Per-frame control signals (all (T,) unless noted) that the planners add to.

    yaw: facing, rad (unwrapped). pelvis: (T, 3) pelvis offset from where the feet put it,
    body frame (z up: a crouch is negative). pelvis_roll / pelvis_twist, trunk_pitch (forward
    lean) / trunk_roll (lean to the right) / trunk_twist, head_yaw / head_pitch (up): rad.
    heel: (T, 2) heel rise of each foot while planted, m. knee_out: (T, 2) knee pole outward, rad.
    arm_swing: arm swing amplitude, rad; arm_walk: 1 where it follows the feet's fore-aft spread
    (walking, running), 0 where it follows their lift (marching). support_sigma_s: smoothing of
    the feet's midpoint into the pelvis path. weight_shift: how far the pelvis moves over the
    stance foot during a step (fraction of the way). load: where the weight rests while both
    feet are down, -1 over the left foot, 0 between, +1 over the right foot (a side-stepper's
    weight goes out with the leading foot). path_xy: (T, 2) where a walker's or runner's centre
    travels, followed where path_w is 1 (instead of the feet's midpoint). elbow_flex: extra
    elbow bend, rad (runners). busy: 1 while a library behaviour (crouch, jump ...) plays: the
    idle sway-shifts-dips and gestures stay out of its way. still: 1 in still segments (idle sway,
    weight shifts and gestures play there). arms: hand targets. tags: (T,) behaviour names.
    """

    t: F64
    yaw: F64
    pelvis: F64
    pelvis_roll: F64
    pelvis_twist: F64
    trunk_pitch: F64
    trunk_roll: F64
    trunk_twist: F64
    head_yaw: F64
    head_pitch: F64
    heel: F64
    knee_out: F64
    arm_swing: F64
    arm_walk: F64
    support_sigma_s: F64
    weight_shift: F64
    load: F64
    path_xy: F64
    path_w: F64
    elbow_flex: F64
    busy: F64
    still: F64
    arms: list[ArmPose] = field(default_factory=list)
    tags: list[str] = field(default_factory=list)

    @classmethod
    def zeros(cls, t: F64, yaw: F64) -> Channels:
        n = t.shape[0]

        def z() -> F64:
            return np.zeros(n)

        return cls(
            t=t,
            yaw=yaw,
            pelvis=np.zeros((n, 3)),
            pelvis_roll=z(),
            pelvis_twist=z(),
            trunk_pitch=z(),
            trunk_roll=z(),
            trunk_twist=z(),
            head_yaw=z(),
            head_pitch=z(),
            heel=np.zeros((n, 2)),
            knee_out=np.zeros((n, 2)),
            arm_swing=z(),
            arm_walk=z(),
            support_sigma_s=np.full(n, 0.12),
            weight_shift=z(),
            load=z(),
            path_xy=np.zeros((n, 2)),
            path_w=z(),
            elbow_flex=z(),
            busy=z(),
            still=z(),
            tags=[""] * n,
        )

    def span(self, t0: float, t1: float) -> NDArray[np.bool_]:
        """Frames in [t0, t1)."""
        return (self.t >= t0 - 1e-9) & (self.t < t1 - 1e-9)

    def tag(self, t0: float, t1: float, name: str) -> None:
        for i in np.flatnonzero(self.span(t0, t1)).tolist():
            self.tags[i] = name

    def yaw_at(self, t: float) -> float:
        return float(np.interp(t, self.t, self.yaw))


@dataclass(slots=True)
class Ctx:
    """What every planner needs: randomness, the person, their feet and the stance they keep.

    stance_xy: (2,) centre between the feet's home places on the floor; it moves when the
    person travels (walking, step-together). width_m: ankle-to-ankle width at rest.
    """

    rng: np.random.Generator
    body: BodyParams
    style: MotionStyle
    feet: Feet
    ch: Channels
    stance_xy: F64
    width_m: float

    def home(self, foot: int, yaw_rad: float, centre: F64 | None = None) -> F64:
        """Where ``foot`` stands at rest around ``centre`` (default: the stance centre) facing ``yaw``."""
        c = self.stance_xy if centre is None else centre
        out: F64 = c + SIDE_SIGN[foot] * self.width_m / 2.0 * right_xy(yaw_rad)
        return out

    def jitter(self, sd_m: float, yaw_rad: float) -> F64:
        """A random floor offset drawn in the facing frame (so a turned routine turns it too)."""
        e = self.rng.normal(0.0, sd_m, 2)
        out: F64 = e[0] * right_xy(yaw_rad) + e[1] * np.array([-math.sin(yaw_rad), math.cos(yaw_rad)])
        return out

    def feet_yaw(self, yaw_rad: float, foot: int) -> float:
        """A planted foot's direction: the facing turned outward by the person's toe-out."""
        return yaw_rad - SIDE_SIGN[foot] * math.radians(self.style.toe_out_deg)
