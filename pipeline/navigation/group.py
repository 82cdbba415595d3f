"""The group rule: one shared command for the room from the chosen people's own commands.

The rule (documented in the README's protocol section):

1. The *members* are the chosen people tracked now (everyone tracked when none are chosen), at
   most ``max_navigators``. A member whose recogniser has no data votes ``still``.
2. Each member votes their own command (``still``, ``forward``, ``left`` or ``right``).
3. The room moves with action A only if a **strict majority of all members** vote A. A tie, or
   no majority (e.g. one forward, one left, one still), resolves to ``still``: nobody is moved
   because of a command most of the room did not give.
4. ``confidence`` = the fraction of members who voted the result, times their mean confidence;
   ``yaw_deg`` = the circular mean of their yaws; ``speed_mps`` = the median of their speeds
   (0 for still); ``position_m`` = the members' centroid.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from pipeline.recognition.types import ActionEstimate
from pipeline.skeleton import ACTIONS


@dataclass(frozen=True, slots=True)
class Vote:
    """One member's own command. position_m: (x, y, z) floor position, metres."""

    user_id: int
    action: ActionEstimate
    position_m: tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class GroupCommand:
    """The room's shared command.

    action: label, probs (the vote shares), yaw_deg, speed_mps.
    members: the user ids that voted. votes: label -> count (all four actions).
    position_m: the members' centroid (x, y, z), metres.
    """

    action: ActionEstimate
    confidence: float
    members: tuple[int, ...]
    votes: dict[str, int]
    position_m: tuple[float, float, float]

    def __post_init__(self) -> None:
        if not self.members:
            raise ValueError("a group command needs at least one member, got none")
        if not 0.0 <= self.confidence <= 1.0:
            raise ValueError(f"confidence must be in [0, 1], got {self.confidence}")


def circular_mean_deg(angles_deg: Sequence[float]) -> float:
    """The mean direction of ``angles_deg`` in (-180, 180] (0 for none or opposite pairs)."""
    if not angles_deg:
        return 0.0
    a = np.radians(np.asarray(angles_deg, dtype=np.float64))
    s, c = float(np.sin(a).sum()), float(np.cos(a).sum())
    if math.hypot(s, c) < 1e-9:
        return 0.0
    deg = math.degrees(math.atan2(s, c))
    return 180.0 if deg <= -180.0 else deg


def group_command(votes: Sequence[Vote]) -> GroupCommand | None:
    """The room's command by the module's rule; None when nobody votes."""
    if not votes:
        return None
    n = len(votes)
    counts = Counter(v.action.label for v in votes)
    leader, top = max(counts.items(), key=lambda kv: (kv[1], kv[0] == "still"))
    tied = sum(1 for c in counts.values() if c == top) > 1
    label = leader if top * 2 > n and not tied else "still"
    agree = [v for v in votes if v.action.label == label]
    share = len(agree) / n
    mean_conf = float(np.mean([v.action.confidence for v in agree])) if agree else 0.0
    yaw = circular_mean_deg([v.action.yaw_deg for v in (agree or votes)])
    speed = float(np.median([v.action.speed_mps for v in agree])) if agree and label != "still" else 0.0
    pos = np.nanmean(np.asarray([v.position_m for v in votes], dtype=np.float64), axis=0)
    pos = np.where(np.isfinite(pos), pos, 0.0)
    probs = {a: counts.get(a, 0) / n for a in ACTIONS}
    return GroupCommand(
        action=ActionEstimate(label, probs, yaw, speed),
        confidence=min(1.0, max(0.0, share * mean_conf)),
        members=tuple(v.user_id for v in votes),
        votes={a: counts.get(a, 0) for a in ACTIONS},
        position_m=(float(pos[0]), float(pos[1]), float(pos[2])),
    )
