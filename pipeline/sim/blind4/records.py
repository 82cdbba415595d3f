"""Plan records shared by the planner stages: swings, events, bouts and the whole plan."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pipeline.sim.blind4.mathutil import FPS

LEFT, RIGHT = 0, 1
MAX_GAP = round(1.0 * FPS)  # longest double-support gap inside a bout
LABELS = ("still", "forward", "left", "right")


@dataclass
class Swing:
    """One foot swing; the foot is airborne on frames lo .. td-1 and lands at frame td."""

    foot: int
    lo: int
    td: int
    p0: NDArray[np.float64]
    p1: NDArray[np.float64]
    yaw0: float
    yaw1: float
    apex: float
    kind: str
    reach: float = 0.0  # forward ankle excursion at the apex (knee lift), metres
    heel: float = 0.0  # ankle rise at heel-off, reached at lift-off
    heel_frames: int = 0  # duration of the heel-off phase before ``lo``
    land: float = 0.0  # ankle height at touch-down (toe-first landing)
    land_frames: int = 0  # frames for the heel to come down after ``td``
    peak: float = 0.5  # normalised time of the apex


@dataclass
class Event:
    """A non-locomotor behaviour rendered by the upper-body module."""

    kind: str
    start: int
    end: int
    params: dict[str, float] = field(default_factory=dict)


@dataclass
class Bout:
    """A labelled stepping bout, frames start..end inclusive."""

    start: int
    end: int
    label: str
    tag: str
    cadence: float
    arm_mode: str


@dataclass
class Plan:
    """Everything the kinematic stages need, plus the ground-truth annotation."""

    n_frames: int
    init_pos: NDArray[np.float64]  # (2, 2) floor positions of the ankles
    init_yaw: NDArray[np.float64]  # (2,) foot yaws
    swings: list[Swing]
    bouts: list[Bout]
    events: list[Event]
    labels: NDArray[np.str_]
    tags: NDArray[np.str_]
    w_base: NDArray[np.float64]  # (T,) weight fraction on the left foot when standing
    zmp_ap: NDArray[np.float64]  # (T,) anterior-posterior ZMP offset (m)
    arm_swing: NDArray[np.float64]  # (T,) arm swing amplitude (rad)
    arm_abduct: NDArray[np.float64]  # (T,) side-step arm abduction amplitude (rad)


def sec_frames(rng: np.random.Generator, lo: float, hi: float) -> int:
    """Random duration in frames."""
    return round(rng.uniform(lo, hi) * FPS)
