"""The session script: MSSQ (once, first session) -> SSQ pre -> the run (N minutes, counted down and
stopped by the server) -> SSQ post -> IPQ -> NASA-TLX, with each step's state.

The participant page walks the questionnaire steps one at a time; the dashboard shows all of them.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy.orm import Session

from app.db.models import StudySession
from app.db.study_repository import in_use

#: (key, label, instrument, phase) in the order of the script; "run" is the session itself.
STEPS: tuple[tuple[str, str, str | None, str | None], ...] = (
    ("mssq", "MSSQ (motion sickness susceptibility, once)", "mssq", "pre"),
    ("ssq_pre", "SSQ before the session", "ssq", "pre"),
    ("run", "Run", None, None),
    ("ssq_post", "SSQ after the session", "ssq", "post"),
    ("ipq", "IPQ (presence)", "ipq", "post"),
    ("nasa_tlx", "NASA-TLX (workload)", "nasa_tlx", "post"),
)


def _needs_mssq(session: StudySession) -> bool:
    """The MSSQ belongs to the participant's first session (or to this one, if it holds it)."""
    others = [s for s in session.participant.sessions if s.excluded_at is None]
    holder = next((s for s in others for q in s.questionnaires if q.instrument == "mssq" and in_use(q)), None)
    if holder is not None:
        return holder.id == session.id
    first = min(others, key=lambda s: (s.planned_index or 9, s.id), default=session)
    return first.id == session.id


def session_script(db: Session, session: StudySession) -> dict[str, Any]:
    """Every step of the script with its state (``done``, ``current``, ``todo``, ``running``)."""
    now = datetime.now(UTC)
    steps: list[dict[str, Any]] = []
    for key, label, instrument, phase in STEPS:
        if key == "mssq" and not _needs_mssq(session):
            continue
        step: dict[str, Any] = {"key": key, "label": label, "instrument": instrument, "phase": phase}
        if instrument is None:
            step["kind"] = "run"
            step["planned_duration_s"] = session.planned_duration_s
            if session.status == "stopped":
                state = "done"
            elif session.status == "running":
                state = "running"
            else:
                state = "todo"
            if session.started_at is not None:
                step["started_at"] = session.started_at.isoformat()
                end = session.stopped_at or now
                step["elapsed_s"] = round((end - session.started_at).total_seconds(), 1)
                if session.planned_duration_s is not None:
                    ends = session.started_at.timestamp() + session.planned_duration_s
                    step["ends_at"] = datetime.fromtimestamp(ends, UTC).isoformat()
                    if session.status == "running":
                        step["remaining_s"] = round(max(0.0, ends - now.timestamp()), 1)
        else:
            step["kind"] = "questionnaire"
            holders = [session] if key != "mssq" else list(session.participant.sessions)
            entry = next(
                (
                    q
                    for s in holders
                    for q in s.questionnaires
                    if q.instrument == instrument and q.phase == phase and in_use(q)
                ),
                None,
            )
            step["entry_id"] = entry.id if entry is not None else None
            state = "done" if entry is not None else "todo"
        step["state"] = state
        steps.append(step)
    current = next((s for s in steps if s["state"] != "done"), None)
    if current is not None and current["state"] == "todo":
        current["state"] = "current"
    return {
        "session_id": session.id,
        "status": session.status,
        "condition": session.condition,
        "steps": steps,
        "current": current["key"] if current is not None else None,
        "complete": current is None,
    }
