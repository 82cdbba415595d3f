"""The ground truth a blind2 script records: the label and tag vocabularies, and its bouts, turns
and behaviours.

Labels are ``still``, ``forward`` (marching in place), ``left`` and ``right`` (side steps toward
that side of the facing at the bout's start). Tags name what a person does over a bout or a
behaviour's frames (``""`` for plain standing).
"""

from __future__ import annotations

from dataclasses import dataclass

LABELS = ("still", "forward", "left", "right")
SIDE_KINDS = ("side-step-out-back", "step-together", "shuffle")  # the kinds of side-step bout
STEP_TAGS = ("march", *SIDE_KINDS)
STILL_BEHAVIOURS = (
    "wave",
    "point",
    "look-around",
    "reach",
    "stretch",
    "bow",
    "cross-arms",
    "weight-shift",
    "squat",
    "turn",
)
TAGS = (*STEP_TAGS, *STILL_BEHAVIOURS)
FOOT_NAMES = ("left", "right")  # foot 0, foot 1


@dataclass(frozen=True, slots=True)
class Bout:
    """One stepping bout: frames start…end (first lift-off … last touch-down), its label and tag.

    yaw_rad: the facing at its start; first_foot: the foot that lifts first; gaps_s: the
    both-feet-down gaps between its steps. Marching sets cadence_hz, knee_lift_m and n_steps;
    side steps set width_m, n_reps and lift_m.
    """

    start: int
    end: int
    label: str
    tag: str
    yaw_rad: float
    first_foot: str
    gaps_s: tuple[float, ...]
    cadence_hz: float | None = None
    knee_lift_m: float | None = None
    n_steps: int | None = None
    width_m: float | None = None
    n_reps: int | None = None
    lift_m: float | None = None

    def __post_init__(self) -> None:
        if self.label not in LABELS[1:] or self.tag not in STEP_TAGS:
            raise ValueError(
                f"a bout needs a label from {LABELS[1:]} and a tag from {STEP_TAGS}, "
                f"got {self.label!r}, {self.tag!r}"
            )
        if not 0 <= self.start < self.end:
            raise ValueError(f"a bout needs 0 <= start < end, got {self.start}, {self.end}")
        if self.first_foot not in FOOT_NAMES:
            raise ValueError(f"first_foot must be one of {FOOT_NAMES}, got {self.first_foot!r}")


@dataclass(frozen=True, slots=True)
class Turn:
    """A turn on the spot over frames start…end; its pivot steps lift first at first_lift and land
    last at last_touch; yaw_change_rad is the planned rotation (counter-clockwise positive)."""

    start: int
    end: int
    first_lift: int
    last_touch: int
    yaw_change_rad: float
    n_steps: int

    def __post_init__(self) -> None:
        if not self.start <= self.first_lift < self.last_touch <= self.end:
            raise ValueError(
                "a turn needs start <= first_lift < last_touch <= end, got "
                f"{self.start}, {self.first_lift}, {self.last_touch}, {self.end}"
            )


@dataclass(frozen=True, slots=True)
class Behaviour:
    """A still behaviour (tag from STILL_BEHAVIOURS) over frames start…end."""

    tag: str
    start: int
    end: int

    def __post_init__(self) -> None:
        if self.tag not in STILL_BEHAVIOURS or not 0 <= self.start <= self.end:
            raise ValueError(f"bad behaviour {self.tag!r} over {self.start}…{self.end}")
