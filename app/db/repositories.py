"""Reading and writing the database: one function per use, a SQLAlchemy ``Session`` passed in.

Functions raise :class:`RecordNotFound` or :class:`StateConflict` (mapped to HTTP 404 and
409 by the app) and never commit half a change: a rejected request leaves the rows as they were.
The study's records (participants, sessions, questionnaires, audit trail) live in
:mod:`app.db.study_repository` and are re-exported here.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

from sqlalchemy import insert, select, update
from sqlalchemy.orm import Session

from app.db.errors import DesignRuleViolation, RecordNotFound, StateConflict
from app.db.models import CalibrationRun, Event, utcnow
from app.db.study_repository import (
    Change,
    add_questionnaire,
    check_questionnaire,
    create_participant,
    create_participant_link,
    create_session,
    delete_participant,
    delete_session,
    get_participant,
    get_questionnaire,
    get_session,
    in_use,
    list_audit,
    list_participants,
    list_questionnaires,
    list_sessions,
    next_first_condition,
    running_session,
    session_for_link,
    set_participant_excluded,
    set_questionnaire_excluded,
    set_session_excluded,
    start_session,
    stop_session,
    update_participant,
    update_session,
    update_session_notes,
)

__all__ = [
    "Change",
    "DesignRuleViolation",
    "RecordNotFound",
    "StateConflict",
    "activate_calibration_run",
    "active_calibration_run",
    "add_events",
    "add_questionnaire",
    "check_questionnaire",
    "create_calibration_run",
    "create_participant",
    "create_participant_link",
    "create_session",
    "delete_participant",
    "delete_session",
    "fail_unfinished_calibration_runs",
    "finish_calibration_run",
    "get_calibration_run",
    "get_participant",
    "get_questionnaire",
    "get_session",
    "in_use",
    "list_audit",
    "list_calibration_runs",
    "list_events",
    "list_participants",
    "list_questionnaires",
    "list_sessions",
    "next_first_condition",
    "running_session",
    "session_for_link",
    "set_participant_excluded",
    "set_questionnaire_excluded",
    "set_session_excluded",
    "start_session",
    "stop_session",
    "update_calibration_run",
    "update_participant",
    "update_session",
    "update_session_notes",
]


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
    """Mark a run done with its result, in one commit. It waits for the operator to accept it
    (:func:`activate_calibration_run`) after comparing it with the active one: it is not active yet."""
    row = get_calibration_run(db, run_id)
    row.status, row.progress, row.message, row.result = "done", 1.0, message, result
    db.commit()
    return row


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
