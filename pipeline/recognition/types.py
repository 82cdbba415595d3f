"""What the recognition stage hands on: the navigator's command for one frame."""

from __future__ import annotations

from dataclasses import dataclass, field

from pipeline.recognition.bout import GateVerdict
from pipeline.recognition.steps import StepFrame
from pipeline.skeleton import ACTIONS


@dataclass(frozen=True, slots=True)
class ActionEstimate:
    """The recognised locomotion command.

    label: one of ``still``, ``forward``, ``left``, ``right`` (after smoothing and hysteresis).
    probs: smoothed class probabilities, keys = ACTIONS, summing to 1 (all 0 when there is no data).
    yaw_deg: facing direction in the CAVE frame, 0 = +Y, counter-clockwise positive, (-180, 180].
    speed_mps: intended walking speed, metres per second (0 when still).
    steps: the frame's step evidence (contacts, lift-offs, the stepping foot's displacement), if any.
    gate: the stepping-bout gate's verdict (why the command is what it is), if the gate is on.
    no_data: True when the recogniser has no usable skeleton (no leg joint known for longer than
        its ``max_gap_s``, or never): the label is then ``still`` with confidence 0.
    """

    label: str
    probs: dict[str, float] = field(default_factory=dict)
    yaw_deg: float = 0.0
    speed_mps: float = 0.0
    no_data: bool = False
    steps: StepFrame | None = None
    gate: GateVerdict | None = None

    def __post_init__(self) -> None:
        if self.label not in ACTIONS:
            raise ValueError(f"label must be one of {ACTIONS}, got {self.label!r}")
        if self.no_data and (self.label != "still" or any(self.probs.values())):
            raise ValueError("an estimate without data must be still with all probabilities 0")

    @property
    def confidence(self) -> float:
        return float(self.probs.get(self.label, 0.0))
