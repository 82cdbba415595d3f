"""The within-subject design: counterbalanced order, the gap between sessions, completeness.

The paper's design: every participant does both conditions, controller (``CC``) and embodied
(``EC``), on different days (two days apart), half of them CC first and half EC first. Before
and after each session the SSQ; after each session the IPQ and the NASA-TLX; the MSSQ once.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

from app.study.config import DesignConfig
from app.study.data import CONDITIONS, StudyData

#: The questionnaires every session needs: (instrument, phase); phase None = any phase.
PER_SESSION: tuple[tuple[str, str | None], ...] = (
    ("ssq", "pre"),
    ("ssq", "post"),
    ("ipq", None),
    ("nasa_tlx", None),
)


def order_for(first: str) -> tuple[str, str]:
    """The two conditions in the order a participant does them."""
    if first not in CONDITIONS:
        raise ValueError(f"first condition must be one of {CONDITIONS}, got {first!r}")
    return (first, "EC" if first == "CC" else "CC")


def next_first_condition(assigned: Iterable[str | None]) -> str:
    """The first condition for the next participant: the one used less so far (CC on a tie).

    Adding participants one by one this alternates CC, EC, CC, ... so the groups never differ
    by more than one, whatever N turns out to be.
    """
    counts = Counter(c for c in assigned if c in CONDITIONS)
    return "CC" if counts["CC"] <= counts["EC"] else "EC"


def counterbalanced_orders(n: int) -> list[tuple[str, str]]:
    """Orders for ``n`` participants: half CC first, half EC first (alternating)."""
    if n < 0:
        raise ValueError(f"n must be >= 0, got {n}")
    assigned: list[str | None] = []
    for _ in range(n):
        assigned.append(next_first_condition(assigned))
    return [order_for(str(c)) for c in assigned]


@dataclass(frozen=True, slots=True)
class GapWarning:
    participant_id: int
    code: str
    session_ids: tuple[int, int]
    gap_days: float
    min_gap_days: float

    @property
    def message(self) -> str:
        return (
            f"participant {self.code}: sessions {self.session_ids[0]} and {self.session_ids[1]} are "
            f"{self.gap_days:.2f} days apart, less than the minimum of {self.min_gap_days:g} days"
        )

    def as_dict(self) -> dict[str, Any]:
        return {
            "participant_id": self.participant_id,
            "code": self.code,
            "session_ids": list(self.session_ids),
            "gap_days": round(self.gap_days, 3),
            "min_gap_days": self.min_gap_days,
            "message": self.message,
        }


def gap_warnings(data: StudyData, min_gap_days: float) -> list[GapWarning]:
    """A warning for each pair of a participant's consecutive started sessions closer than the gap."""
    out: list[GapWarning] = []
    for p in data.participants:
        started = sorted((s.started_at, s.id) for s in data.sessions_of(p.id) if s.started_at is not None)
        for (t_a, id_a), (t_b, id_b) in pairwise(started):
            gap = (t_b - t_a).total_seconds() / 86400.0
            if gap < min_gap_days:
                out.append(GapWarning(p.id, p.code, (id_a, id_b), gap, min_gap_days))
    return out


def completeness(data: StudyData) -> list[dict[str, Any]]:
    """Per participant: the conditions without a session and the questionnaires still missing."""
    out: list[dict[str, Any]] = []
    for p in data.participants:
        sessions = data.sessions_of(p.id)
        missing: list[dict[str, Any]] = []
        has_mssq = False
        for s in sessions:
            responses = data.responses_of(s.id)
            has_mssq = has_mssq or any(r.instrument == "mssq" for r in responses)
            for instrument, phase in PER_SESSION:
                if not any(
                    r.instrument == instrument and (phase is None or r.phase == phase) for r in responses
                ):
                    missing.append(
                        {
                            "session_id": s.id,
                            "condition": s.condition,
                            "instrument": instrument,
                            "phase": phase,
                        }
                    )
        if not has_mssq:
            missing.append({"session_id": None, "condition": None, "instrument": "mssq", "phase": None})
        conditions = {s.condition for s in sessions}
        missing_conditions = [c for c in CONDITIONS if c not in conditions]
        out.append(
            {
                "participant_id": p.id,
                "code": p.code,
                "sessions": len(sessions),
                "missing_conditions": missing_conditions,
                "missing": missing,
                "complete": not missing and not missing_conditions,
            }
        )
    return out


def completed_both(data: StudyData, participant_id: int) -> bool:
    """The participant ran a session in each condition (both stopped)."""
    ran = {s.condition for s in data.sessions_of(participant_id) if s.status == "stopped"}
    return all(c in ran for c in CONDITIONS)


def design_summary(data: StudyData, config: DesignConfig) -> dict[str, Any]:
    """Everything the study panel shows about the design, JSON-able.

    The design counts (CC first / EC first, balanced) are over the participants who completed both
    conditions; those still incomplete are listed, and counted only in the enrolment counts (which
    the next participant's order balances). Excluded participants count nowhere.
    """
    registered = len(data.participants)
    data = data.analysed()
    firsts = [p.first_condition for p in data.participants]
    enrolled = Counter(c for c in firsts if c is not None)
    done = [p for p in data.participants if completed_both(data, p.id)]
    counts = Counter(p.first_condition for p in done if p.first_condition is not None)
    nxt = next_first_condition(firsts)
    return {
        "participants": registered,
        "completed_participants": len(done),
        "incomplete": [p.code for p in data.participants if p not in done],
        "first_condition_counts": {c: counts[c] for c in CONDITIONS},
        "enrolled_first_condition_counts": {c: enrolled[c] for c in CONDITIONS},
        "balanced": abs(counts["CC"] - counts["EC"]) <= 1,
        "next_first_condition": nxt,
        "next_order": list(order_for(nxt)),
        "min_gap_days": config.min_gap_days,
        "gap_warnings": [w.as_dict() for w in gap_warnings(data, config.min_gap_days)],
        "completeness": completeness(data),
    }
