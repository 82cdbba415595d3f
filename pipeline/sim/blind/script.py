"""The ground truth of what a simulated person does: foot moves, posture curves, labelled bouts.

Stepping activities (marching, side steps, pivot turns) are lists of :class:`Move` — one foot's
swing from a planted position to a new planted position — and every other behaviour writes smooth
offsets into the :class:`Posture` channels (``activities.py`` builds both). Labels come from this
ground truth alone (:func:`frame_labels`): a stepping bout is labelled from its first lift-off to
its last touch-down, a pause of up to 1.0 s between two of its steps keeps the label, and
everything else is ``still``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import InputError
from pipeline.sim.blind.timing import LAWS, FloatArray

LEFT, RIGHT = 0, 1
MAX_PAUSE_S = 1.0  # the label rule: a pause up to this long between two steps keeps the bout's label
MOVING_LABELS = ("forward", "left", "right")


def right_of(yaw_deg: float) -> NDArray[np.float64]:
    """Unit vector to the right (xy) of someone facing ``yaw_deg`` (0 = +Y, counter-clockwise)."""
    a = math.radians(yaw_deg)
    return np.array([math.cos(a), math.sin(a)])


def forward_of(yaw_deg: float) -> NDArray[np.float64]:
    """Unit facing vector (xy) of ``yaw_deg``."""
    a = math.radians(yaw_deg)
    return np.array([-math.sin(a), math.cos(a)])


@dataclass(frozen=True, slots=True)
class Move:
    """One foot's swing: airborne after frame ``off_f``, planted again at frame ``on_f``.

    The foot's contact is false for off_f < k < on_f. Positions are the ankle's xy in the CAVE frame
    (metres), yaws the foot's pointing direction (degrees, 0 = +Y). lift_m: the ankle's peak rise
    above its standing height. fore_aft_m: the ankle's peak offset mid-swing along the foot's forward
    direction (negative: heel kicked back). law / peak_frac / hold_frac shape the rise and fall;
    delay_frac: the share of the swing at each end where the foot only rises or lands vertically.
    """

    foot: int
    off_f: int
    on_f: int
    start_xy: tuple[float, float]
    end_xy: tuple[float, float]
    start_yaw_deg: float
    end_yaw_deg: float
    lift_m: float
    law: str
    peak_frac: float
    hold_frac: float
    delay_frac: float
    fore_aft_m: float

    def __post_init__(self) -> None:
        if self.foot not in (LEFT, RIGHT):
            raise InputError(f"foot must be 0 (left) or 1 (right), got {self.foot}")
        if self.off_f < 0 or self.on_f - self.off_f < 3:
            raise InputError(f"a move needs 0 <= off_f and on_f - off_f >= 3, got {self.off_f}..{self.on_f}")
        if not 0.0 < self.lift_m <= 0.4:
            raise InputError(f"lift_m must be in (0, 0.4] m, got {self.lift_m}")
        if self.law not in LAWS:
            raise InputError(f"law must be one of {list(LAWS)}, got {self.law!r}")
        if not (self.peak_frac >= 0.1 and self.peak_frac + self.hold_frac <= 0.85):
            raise InputError(f"peak_frac {self.peak_frac} + hold_frac {self.hold_frac} must fit in 0.1..0.85")
        if not 0.0 <= self.delay_frac <= 0.3:
            raise InputError(f"delay_frac must be in [0, 0.3], got {self.delay_frac}")

    @property
    def lateral_m(self) -> float:
        """Displacement towards the right of the foot's starting yaw (negative: to the left)."""
        d = np.subtract(self.end_xy, self.start_xy)
        return float(d @ right_of(self.start_yaw_deg))


@dataclass(frozen=True, slots=True)
class Bout:
    """One activity over frames start_f..end_f (inclusive).

    label: what its stepping frames are (``forward``, ``left``, ``right``), or ``still`` for an
    activity that is not locomotion, even when its feet move (a turn's pivot steps). tag: the
    behaviour's name. moves: the foot swings it makes, in time order.
    """

    tag: str
    label: str
    start_f: int
    end_f: int
    moves: tuple[Move, ...] = ()

    def __post_init__(self) -> None:
        if self.label not in ("still", *MOVING_LABELS):
            raise InputError(f"a bout's label must be still, forward, left or right, got {self.label!r}")
        if self.end_f < self.start_f:
            raise InputError(f"a bout must not end (frame {self.end_f}) before it starts ({self.start_f})")
        if self.label != "still" and not self.moves:
            raise InputError(f"a {self.label} bout needs foot moves")


@dataclass(frozen=True, slots=True)
class Posture:
    """Per-frame offsets from a person's rest posture, degrees or metres as named; (T,) or (T, 2).

    The (T, 2) arm channels are [left arm, right arm]. arm_alpha: flexion (raises the arm forwards),
    arm_beta: abduction (raises it sideways), elbow: flexion, arm_rot: external rotation of the
    upper arm. weight_bias: −1 all weight on the left foot … +1 on the right. pelvis_back_m moves the
    pelvis backwards (bow, squat), pelvis_drop_m lowers it.
    """

    trunk_pitch_deg: FloatArray
    trunk_roll_deg: FloatArray
    trunk_twist_deg: FloatArray
    head_yaw_deg: FloatArray
    head_pitch_deg: FloatArray
    pelvis_drop_m: FloatArray
    pelvis_back_m: FloatArray
    weight_bias: FloatArray
    arm_alpha_deg: FloatArray
    arm_beta_deg: FloatArray
    elbow_deg: FloatArray
    arm_rot_deg: FloatArray

    @staticmethod
    def zeros(n: int) -> Posture:
        one = [np.zeros(n) for _ in range(8)]
        two = [np.zeros((n, 2)) for _ in range(4)]
        return Posture(*one, *two)


@dataclass(frozen=True, slots=True)
class Script:
    """Everything a person does in one sequence (the generator's ground truth)."""

    fps: float
    n_frames: int
    yaw0_deg: float
    feet0_xy: tuple[tuple[float, float], tuple[float, float]]
    bouts: tuple[Bout, ...]
    posture: Posture

    @property
    def moves(self) -> tuple[Move, ...]:
        return tuple(sorted((m for b in self.bouts for m in b.moves), key=lambda m: (m.off_f, m.foot)))


def stepping_runs(bout: Bout, fps: float) -> list[tuple[int, int]]:
    """The bout's labelled frame runs (first, last inclusive): lift-off to touch-down, pauses ≤ 1.0 s kept."""
    runs: list[tuple[int, int]] = []
    for m in sorted(bout.moves, key=lambda m: m.off_f):
        first, last = m.off_f + 1, m.on_f
        # both feet down from the previous touch-down to the frame before this lift-off
        if runs and (first - runs[-1][1]) / fps <= MAX_PAUSE_S:
            runs[-1] = (runs[-1][0], max(runs[-1][1], last))
        else:
            runs.append((first, last))
    return runs


def frame_labels(script: Script) -> tuple[list[str], list[str]]:
    """Per-frame labels and tags from the script's bouts (the label rules of the module docstring)."""
    labels = ["still"] * script.n_frames
    tags = [""] * script.n_frames
    for b in script.bouts:
        if b.label == "still":
            for k in range(b.start_f, min(b.end_f, script.n_frames - 1) + 1):
                tags[k] = b.tag
            continue
        for first, last in stepping_runs(b, script.fps):
            for k in range(first, min(last, script.n_frames - 1) + 1):
                labels[k] = b.label
                tags[k] = b.tag
    return labels, tags
