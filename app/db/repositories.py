"""Reading and writing the database: one function per use, a SQLAlchemy ``Session`` passed in.

Functions raise :class:`RecordNotFound` or :class:`StateConflict` (mapped to HTTP 404 and
409 by the app) and never commit half a change: a rejected request leaves the rows as they were.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from sqlalchemy import func, insert, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

from app.db.models import (
    CONDITIONS,
    CalibrationRun,
    Event,
    Participant,
    QuestionnaireResponse,
    StudySession,
    utcnow,
)


class RecordNotFound(LookupError):
    """The requested row does not exist."""


class StateConflict(Exception):
    """The request contradicts the stored state (duplicate code, session already running ...)."""


# --- participants -------------------------------------------------------------------------


def next_first_condition(db: Session) -> str:
    """The counterbalanced first condition for the next participant: the rarer one so far, CC on a tie."""
    counts = dict.fromkeys(CONDITIONS, 0)
    rows = db.execute(
        select(Participant.first_condition, func.count()).group_by(Participant.first_condition)
    ).all()
    for cond, n in rows:
        if cond in counts:
            counts[cond] = int(n)
    return "EC" if counts["EC"] < counts["CC"] else "CC"


def create_participant(db: Session, code: str, first_condition: str | None, notes: str) -> Participant:
    if db.scalar(select(Participant.id).where(Participant.code == code)) is not None:
        raise StateConflict(f"participant code {code!r} already exists")
    row = Participant(
        code=code,
        first_condition=first_condition or next_first_condition(db),
        notes=notes,
        created_at=utcnow(),
    )
    db.add(row)
    try:
        db.commit()
    except IntegrityError as exc:
        db.rollback()
        raise StateConflict(f"participant code {code!r} already exists") from exc
    return row


def list_participants(db: Session) -> Sequence[Participant]:
    return db.scalars(select(Participant).order_by(Participant.id)).all()


def get_participant(db: Session, participant_id: int) -> Participant:
    row = db.get(Participant, participant_id)
    if row is None:
        raise RecordNotFound(f"participant {participant_id} not found")
    return row


def update_participant(
    db: Session, participant_id: int, first_condition: str | None, notes: str | None
) -> Participant:
    row = get_participant(db, participant_id)
    if first_condition is not None:
        row.first_condition = first_condition
    if notes is not None:
        row.notes = notes
    db.commit()
    return row


# --- study sessions -----------------------------------------------------------------------


def create_session(
    db: Session, participant_id: int, condition: str, planned_index: int | None, notes: str
) -> StudySession:
    participant = get_participant(db, participant_id)
    if planned_index is None and participant.first_condition is not None:
        planned_index = 1 if condition == participant.first_condition else 2
    row = StudySession(
        participant_id=participant.id,
        condition=condition,
        planned_index=planned_index,
        status="planned",
        notes=notes,
        created_at=utcnow(),
    )
    db.add(row)
    db.commit()
    return row


def list_sessions(db: Session, participant_id: int | None = None) -> Sequence[StudySession]:
    q = select(StudySession).order_by(StudySession.id)
    if participant_id is not None:
        q = q.where(StudySession.participant_id == participant_id)
    return db.scalars(q).all()


def get_session(db: Session, session_id: int) -> StudySession:
    row = db.get(StudySession, session_id)
    if row is None:
        raise RecordNotFound(f"session {session_id} not found")
    return row


def running_session(db: Session) -> StudySession | None:
    return db.scalars(
        select(StudySession).where(StudySession.status == "running").order_by(StudySession.id)
    ).first()


def start_session(db: Session, session_id: int, ts: float) -> StudySession:
    """planned -> running (one running session at a time); writes a ``session`` event."""
    row = get_session(db, session_id)
    if row.status != "planned":
        raise StateConflict(f"session {session_id} is {row.status}; only a planned session can start")
    other = running_session(db)
    if other is not None:
        raise StateConflict(f"session {other.id} is still running; stop it first")
    row.status = "running"
    row.started_at = utcnow()
    db.add(Event(session_id=row.id, ts=ts, kind="session", payload={"state": "running"}))
    db.commit()
    return row


def stop_session(db: Session, session_id: int, ts: float) -> StudySession:
    """running -> stopped; writes a ``session`` event."""
    row = get_session(db, session_id)
    if row.status != "running":
        raise StateConflict(f"session {session_id} is {row.status}; only a running session can stop")
    row.status = "stopped"
    row.stopped_at = utcnow()
    db.add(Event(session_id=row.id, ts=ts, kind="session", payload={"state": "stopped"}))
    db.commit()
    return row


def update_session_notes(db: Session, session_id: int, notes: str) -> StudySession:
    row = get_session(db, session_id)
    row.notes = notes
    db.commit()
    return row


# --- events -------------------------------------------------------------------------------


def add_events(db: Session, rows: Iterable[dict[str, Any]]) -> int:
    """Insert many events at once (dicts with session_id, ts, kind, payload); returns the count."""
    batch = list(rows)
    if batch:
        db.execute(insert(Event), batch)
        db.commit()
    return len(batch)


def list_events(
    db: Session,
    session_id: int | None = None,
    kind: str | None = None,
    since_ts: float | None = None,
    limit: int = 1000,
) -> Sequence[Event]:
    q = select(Event).order_by(Event.ts, Event.id).limit(limit)
    if session_id is not None:
        q = q.where(Event.session_id == session_id)
    if kind is not None:
        q = q.where(Event.kind == kind)
    if since_ts is not None:
        q = q.where(Event.ts >= since_ts)
    return db.scalars(q).all()


# --- questionnaires -----------------------------------------------------------------------


def add_questionnaire(
    db: Session,
    session_id: int,
    instrument: str,
    phase: str | None,
    answers: dict[str, Any],
    pairwise: dict[str, Any] | None,
    scores: dict[str, float],
) -> QuestionnaireResponse:
    get_session(db, session_id)
    row = QuestionnaireResponse(
        session_id=session_id,
        instrument=instrument,
        phase=phase,
        answers=answers,
        pairwise=pairwise,
        scores=scores,
        created_at=utcnow(),
    )
    db.add(row)
    db.commit()
    return row


def list_questionnaires(db: Session, session_id: int) -> Sequence[QuestionnaireResponse]:
    get_session(db, session_id)
    return db.scalars(
        select(QuestionnaireResponse)
        .where(QuestionnaireResponse.session_id == session_id)
        .order_by(QuestionnaireResponse.id)
    ).all()


# --- calibration runs ---------------------------------------------------------------------


def create_calibration_run(db: Session) -> CalibrationRun:
    running = db.scalars(
        select(CalibrationRun).where(CalibrationRun.status.in_(("pending", "running")))
    ).first()
    if running is not None:
        raise StateConflict(f"calibration run {running.id} is still {running.status}")
    row = CalibrationRun(created_at=utcnow(), status="pending", progress=0.0, message="queued")
    db.add(row)
    db.commit()
    return row


def update_calibration_run(
    db: Session,
    run_id: int,
    *,
    status: str | None = None,
    progress: float | None = None,
    message: str | None = None,
    result: dict[str, Any] | None = None,
) -> CalibrationRun:
    row = get_calibration_run(db, run_id)
    if status is not None:
        row.status = status
    if progress is not None:
        row.progress = float(progress)
    if message is not None:
        row.message = message
    if result is not None:
        row.result = result
    db.commit()
    return row


def list_calibration_runs(db: Session) -> Sequence[CalibrationRun]:
    return db.scalars(select(CalibrationRun).order_by(CalibrationRun.id.desc())).all()


def get_calibration_run(db: Session, run_id: int) -> CalibrationRun:
    row = db.get(CalibrationRun, run_id)
    if row is None:
        raise RecordNotFound(f"calibration run {run_id} not found")
    return row


def active_calibration_run(db: Session) -> CalibrationRun | None:
    return db.scalars(select(CalibrationRun).where(CalibrationRun.active.is_(True))).first()


def activate_calibration_run(db: Session, run_id: int) -> CalibrationRun:
    """Make a finished run the active one (accept, or roll back to an earlier one)."""
    row = get_calibration_run(db, run_id)
    if row.status != "done" or row.result is None:
        raise StateConflict(f"calibration run {run_id} is {row.status}; only a finished run can be active")
    return _make_active(db, row)


def finish_calibration_run(db: Session, run_id: int, message: str, result: dict[str, Any]) -> CalibrationRun:
    """Mark a run done with its result and make it the active one in one transaction, so that
    no reader sees it done but not yet active."""
    row = get_calibration_run(db, run_id)
    row.status, row.progress, row.message, row.result = "done", 1.0, message, result
    return _make_active(db, row)


def _make_active(db: Session, row: CalibrationRun) -> CalibrationRun:
    db.execute(update(CalibrationRun).where(CalibrationRun.id != row.id).values(active=False))
    row.active = True
    db.commit()
    return row


def fail_unfinished_calibration_runs(db: Session, message: str) -> int:
    """Runs left pending/running by a previous process can never finish: mark them failed."""
    res = db.execute(
        update(CalibrationRun)
        .where(CalibrationRun.status.in_(("pending", "running")))
        .values(status="failed", message=message)
    )
    db.commit()
    return int(getattr(res, "rowcount", 0) or 0)
