"""The study's records: participants, sessions, questionnaires, their audit trail and participant links.

One function per use, a SQLAlchemy ``Session`` passed in. A rejected request raises before anything
is written (:class:`RecordNotFound` 404, :class:`StateConflict` 409) and leaves the rows as they were.

The study design's rules (:class:`DesignRuleViolation`, 409) can be overridden by the operator: a
:class:`Change` with ``override`` (the reason) lets the request through, and every rule it broke is
written to the audit trail and, as an ``override`` event, to the session's log. Corrections,
exclusions and deletions need a reason and are audited with the record before and after.
"""

from __future__ import annotations

import hashlib
import secrets
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from sqlalchemy import exists, func, select, update
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session, aliased

from app.db.errors import DesignRuleViolation, RecordNotFound, StateConflict
from app.db.models import (
    CONDITIONS,
    AuditEntry,
    Event,
    Participant,
    ParticipantLink,
    QuestionnaireResponse,
    StudySession,
    utcnow,
)

#: The questionnaires filled in once per participant, not per session.
ONCE_PER_PARTICIPANT = ("mssq",)


@dataclass
class Change:
    """Who makes a change and why; ``override`` = the reason to let a design rule pass."""

    actor: str = "operator"
    reason: str | None = None
    override: str | None = None
    broken: list[tuple[str, str]] = field(default_factory=list)  # (rule, message) let through

    def rule(self, rule: str, message: str) -> None:
        """A design rule is broken: 409, unless the operator overrides it (then it is recorded)."""
        if self.override:
            self.broken.append((rule, message))
            return
        raise DesignRuleViolation(
            rule, f'{message}. To record it anyway, send "override_reason" with why (it is logged)'
        )


def _audit(
    db: Session,
    change: Change,
    action: str,
    entity: str,
    entity_id: int,
    before: dict[str, Any] | None,
    after: dict[str, Any] | None,
    reason: str | None = None,
) -> None:
    db.add(
        AuditEntry(
            at=utcnow(),
            actor=change.actor,
            action=action,
            entity=entity,
            entity_id=entity_id,
            before=before,
            after=after,
            reason=reason if reason is not None else (change.reason or ""),
        )
    )


def _log_overrides(db: Session, change: Change, entity: str, entity_id: int, session_id: int | None) -> None:
    """The audit entries and session-log events of the rules ``change`` let through."""
    for rule, message in change.broken:
        after = {"rule": rule, "message": message}
        _audit(db, change, "override", entity, entity_id, None, after, change.override)
        db.add(
            Event(
                session_id=session_id,
                ts=time.time(),
                kind="override",
                payload={
                    **after,
                    "entity": entity,
                    "entity_id": entity_id,
                    "reason": change.override,
                    "by": change.actor,
                },
            )
        )


def _iso(value: Any) -> Any:
    return value.isoformat() if hasattr(value, "isoformat") else value


def participant_dict(p: Participant) -> dict[str, Any]:
    return {
        "code": p.code,
        "first_condition": p.first_condition,
        "notes": p.notes,
        "excluded_at": _iso(p.excluded_at),
        "exclusion_reason": p.exclusion_reason,
    }


def session_dict(s: StudySession) -> dict[str, Any]:
    return {
        "participant_id": s.participant_id,
        "condition": s.condition,
        "planned_index": s.planned_index,
        "status": s.status,
        "started_at": _iso(s.started_at),
        "stopped_at": _iso(s.stopped_at),
        "planned_duration_s": s.planned_duration_s,
        "notes": s.notes,
        "excluded_at": _iso(s.excluded_at),
        "exclusion_reason": s.exclusion_reason,
    }


def questionnaire_dict(q: QuestionnaireResponse) -> dict[str, Any]:
    return {
        "session_id": q.session_id,
        "instrument": q.instrument,
        "phase": q.phase,
        "answers": q.answers,
        "pairwise": q.pairwise,
        "scores": q.scores,
        "entered_by": q.entered_by,
        "corrects_id": q.corrects_id,
        "superseded_by_id": q.superseded_by_id,
        "excluded_at": _iso(q.excluded_at),
        "exclusion_reason": q.exclusion_reason,
    }


# --- participants -------------------------------------------------------------------------


def next_first_condition(db: Session) -> str:
    """The counterbalanced first condition for the next participant: the rarer one so far, CC on a tie."""
    counts = dict.fromkeys(CONDITIONS, 0)
    rows = db.execute(
        select(Participant.first_condition, func.count())
        .where(Participant.excluded_at.is_(None))
        .group_by(Participant.first_condition)
    ).all()
    for cond, n in rows:
        if cond in counts:
            counts[cond] = int(n)
    return "EC" if counts["EC"] < counts["CC"] else "CC"


def _same_code(db: Session, code: str) -> Participant | None:
    return db.scalars(select(Participant).where(func.upper(Participant.code) == code.upper())).first()


def create_participant(
    db: Session, code: str, first_condition: str | None, notes: str, change: Change | None = None
) -> Participant:
    change = change or Change()
    other = _same_code(db, code)
    if other is not None:
        same = "" if other.code == code else f" as {other.code!r} (codes are compared ignoring case)"
        raise StateConflict(f"participant code {code!r} already exists{same}")
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


def _expected_index(first: str | None, condition: str) -> int | None:
    if first is None:
        return None
    return 1 if condition == first else 2


def update_participant(
    db: Session,
    participant_id: int,
    first_condition: str | None,
    notes: str | None,
    change: Change | None = None,
    code: str | None = None,
) -> Participant:
    """Notes, the first condition (planned sessions follow) or, as a correction, the code."""
    change = change or Change()
    row = get_participant(db, participant_id)
    before = participant_dict(row)
    if code is not None and code != row.code:
        other = _same_code(db, code)
        if other is not None and other.id != row.id:
            raise StateConflict(f"participant code {code!r} already exists as {other.code!r}")
        if not change.reason:
            raise StateConflict('changing a participant\'s code is a correction: give a "reason"')
        row.code = code
    if first_condition is not None and first_condition != row.first_condition:
        ran = [s.id for s in row.sessions if s.started_at is not None and s.excluded_at is None]
        if ran:
            change.rule(
                "first_condition_after_run",
                f"participant {row.code} already ran session(s) {ran}: changing the first condition "
                f"now would misstate the order they did the conditions in",
            )
        row.first_condition = first_condition
        for s in row.sessions:
            if s.status == "planned":
                s.planned_index = _expected_index(first_condition, s.condition)
    if notes is not None:
        row.notes = notes
    after = participant_dict(row)
    if after != before:
        db.flush()
        _audit(db, change, "update", "participant", row.id, before, after)
        _log_overrides(db, change, "participant", row.id, None)
    db.commit()
    return row


def set_participant_excluded(db: Session, participant_id: int, excluded: bool, change: Change) -> Participant:
    """Exclude a participant from the analysis (or include them again), with a reason."""
    row = get_participant(db, participant_id)
    if excluded == (row.excluded_at is not None):
        raise StateConflict(f"participant {row.code} is {'already' if excluded else 'not'} excluded")
    before = participant_dict(row)
    row.excluded_at, row.exclusion_reason = (utcnow(), change.reason) if excluded else (None, None)
    _audit(
        db, change, "exclude" if excluded else "include", "participant", row.id, before, participant_dict(row)
    )
    db.commit()
    return row


def delete_participant(db: Session, participant_id: int, change: Change) -> None:
    """Remove a participant entered by mistake: only before any of their sessions started."""
    row = get_participant(db, participant_id)
    ran = [s.id for s in row.sessions if s.started_at is not None]
    if ran:
        raise StateConflict(
            f"participant {row.code} has session(s) {ran} that ran: exclude them instead of deleting"
        )
    for s in list(row.sessions):
        _delete_session_rows(db, s, change)
    _audit(db, change, "delete", "participant", row.id, participant_dict(row), None)
    db.delete(row)
    db.commit()


# --- study sessions -----------------------------------------------------------------------


def _active_sessions(participant: Participant) -> list[StudySession]:
    return [s for s in participant.sessions if s.excluded_at is None]


def create_session(
    db: Session,
    participant_id: int,
    condition: str,
    planned_index: int | None,
    notes: str,
    change: Change | None = None,
    planned_duration_s: float | None = None,
) -> StudySession:
    change = change or Change()
    participant = get_participant(db, participant_id)
    if participant.excluded_at is not None:
        raise StateConflict(f"participant {participant.code} is excluded: include them again first")
    same = [s.id for s in _active_sessions(participant) if s.condition == condition]
    if same:
        change.rule(
            "one_session_per_condition",
            f"participant {participant.code} already has a {condition} session "
            f"({', '.join(map(str, same))}); each participant does each condition once "
            f"(exclude that session to replace it)",
        )
    expected = _expected_index(participant.first_condition, condition)
    if planned_index is None:
        planned_index = expected
    elif expected is not None and planned_index != expected:
        change.rule(
            "planned_index",
            f"planned_index {planned_index} contradicts {participant.code}'s order "
            f"({participant.first_condition} first: {condition} is session {expected})",
        )
    row = StudySession(
        participant_id=participant.id,
        condition=condition,
        planned_index=planned_index,
        status="planned",
        notes=notes,
        planned_duration_s=planned_duration_s,
        created_at=utcnow(),
    )
    db.add(row)
    db.flush()
    _log_overrides(db, change, "session", row.id, row.id)
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


def _rowcount(result: Any) -> int:
    """Rows an UPDATE changed (``CursorResult.rowcount``)."""
    return int(result.rowcount)


def start_session(
    db: Session, session_id: int, ts: float, context: dict[str, Any] | None = None
) -> StudySession:
    """planned -> running (one running session at a time); writes a ``session`` event.

    context: what the event records besides the state (calibration, models, navigator ...).
    """
    row = get_session(db, session_id)
    if row.excluded_at is not None:
        raise StateConflict(f"session {session_id} is excluded; it cannot start")
    if row.participant.excluded_at is not None:
        raise StateConflict(f"participant {row.participant.code} is excluded; include them again first")
    if row.status != "planned":
        raise StateConflict(f"session {session_id} is {row.status}; only a planned session can start")
    other = running_session(db)
    if other is not None:
        raise StateConflict(f"session {other.id} is still running; stop it first")
    # one conditional UPDATE (still planned, none running): of racing starts exactly one wins
    running = aliased(StudySession)
    won = _rowcount(db.execute(
        update(StudySession)
        .where(StudySession.id == session_id, StudySession.status == "planned",
               ~exists().where(running.status == "running"))
        .values(status="running", started_at=utcnow())
        .execution_options(synchronize_session=False)
    ))
    if won != 1:
        db.rollback()
        db.refresh(row)
        other = running_session(db)
        if other is not None and other.id != session_id:
            raise StateConflict(f"session {other.id} is still running; stop it first")
        raise StateConflict(f"session {session_id} is {row.status}; only a planned session can start")
    db.refresh(row)
    payload: dict[str, Any] = {"state": "running", **(context or {})}
    if row.planned_duration_s is not None:
        payload["planned_duration_s"] = row.planned_duration_s
    db.add(Event(session_id=row.id, ts=ts, kind="session", payload=payload))
    db.commit()
    return row


def stop_session(db: Session, session_id: int, ts: float, by: str = "operator") -> StudySession:
    """running -> stopped; writes a ``session`` event (``by``: operator, or timer for the auto-stop)."""
    row = get_session(db, session_id)
    if row.status != "running":
        raise StateConflict(f"session {session_id} is {row.status}; only a running session can stop")
    won = _rowcount(db.execute(  # one conditional UPDATE: of racing stops exactly one wins
        update(StudySession)
        .where(StudySession.id == session_id, StudySession.status == "running")
        .values(status="stopped", stopped_at=utcnow(), stopped_by=by)
        .execution_options(synchronize_session=False)
    ))
    if won != 1:
        db.rollback()
        db.refresh(row)
        raise StateConflict(f"session {session_id} is {row.status}; only a running session can stop")
    db.refresh(row)
    db.add(Event(session_id=row.id, ts=ts, kind="session", payload={"state": "stopped", "by": by}))
    db.commit()
    return row


def update_session(
    db: Session,
    session_id: int,
    notes: str | None,
    planned_duration_s: float | None = None,
    change: Change | None = None,
    clear_duration: bool = False,
) -> StudySession:
    change = change or Change()
    row = get_session(db, session_id)
    before = session_dict(row)
    if notes is not None:
        row.notes = notes
    if planned_duration_s is not None or clear_duration:
        if row.status != "planned":
            raise StateConflict(f"session {session_id} is {row.status}: its run time is fixed")
        row.planned_duration_s = planned_duration_s
    after = session_dict(row)
    if after != before and (before["planned_duration_s"] != after["planned_duration_s"]):
        _audit(db, change, "update", "session", row.id, before, after)
    db.commit()
    return row


def update_session_notes(db: Session, session_id: int, notes: str) -> StudySession:
    return update_session(db, session_id, notes)


def set_session_excluded(db: Session, session_id: int, excluded: bool, change: Change) -> StudySession:
    """Exclude a session from the analysis (an aborted run, a wrong condition ...) or include it again."""
    row = get_session(db, session_id)
    if excluded == (row.excluded_at is not None):
        raise StateConflict(f"session {session_id} is {'already' if excluded else 'not'} excluded")
    if excluded and row.status == "running":
        raise StateConflict(f"session {session_id} is running: stop it first")
    if not excluded:
        same = [
            s.id for s in _active_sessions(row.participant) if s.condition == row.condition and s.id != row.id
        ]
        if same:
            change.rule(
                "one_session_per_condition",
                f"participant {row.participant.code} already has another {row.condition} session "
                f"({', '.join(map(str, same))}) in use",
            )
    before = session_dict(row)
    row.excluded_at, row.exclusion_reason = (utcnow(), change.reason) if excluded else (None, None)
    _audit(db, change, "exclude" if excluded else "include", "session", row.id, before, session_dict(row))
    _log_overrides(db, change, "session", row.id, row.id)
    db.add(
        Event(
            session_id=row.id,
            ts=time.time(),
            kind="correction",
            payload={
                "what": "session excluded" if excluded else "session included",
                "reason": change.reason,
                "by": change.actor,
            },
        )
    )
    db.commit()
    return row


def _delete_session_rows(db: Session, s: StudySession, change: Change) -> None:
    for q in list(s.questionnaires):
        _audit(db, change, "delete", "questionnaire", q.id, questionnaire_dict(q), None)
        db.delete(q)
    for link in db.scalars(select(ParticipantLink).where(ParticipantLink.session_id == s.id)):
        db.delete(link)
    for ev in db.scalars(select(Event).where(Event.session_id == s.id)):
        ev.session_id = None
    _audit(db, change, "delete", "session", s.id, session_dict(s), None)
    db.delete(s)


def delete_session(db: Session, session_id: int, change: Change) -> None:
    """Remove a session planned by mistake: only one that never started."""
    row = get_session(db, session_id)
    if row.started_at is not None:
        raise StateConflict(f"session {session_id} has run: exclude it instead of deleting")
    _delete_session_rows(db, row, change)
    db.commit()


# --- questionnaires -----------------------------------------------------------------------


def in_use(q: QuestionnaireResponse) -> bool:
    """Neither replaced by a correction nor excluded."""
    return q.superseded_by_id is None and q.excluded_at is None


def _describe(instrument: str, phase: str | None) -> str:
    name = {"ssq": "SSQ", "mssq": "MSSQ", "ipq": "IPQ", "nasa_tlx": "NASA-TLX"}.get(instrument, instrument)
    return f"{name} {phase}" if phase else name


def _same_entries(
    db: Session, session: StudySession, instrument: str, phase: str | None
) -> list[QuestionnaireResponse]:
    """The entries in use that a new one would duplicate (for the MSSQ: any of the participant's)."""
    if instrument in ONCE_PER_PARTICIPANT:
        ids = [s.id for s in session.participant.sessions if s.excluded_at is None]
        query = select(QuestionnaireResponse).where(
            QuestionnaireResponse.session_id.in_(ids), QuestionnaireResponse.instrument == instrument
        )
    else:
        query = select(QuestionnaireResponse).where(
            QuestionnaireResponse.session_id == session.id,
            QuestionnaireResponse.instrument == instrument,
            QuestionnaireResponse.phase.is_(None) if phase is None else QuestionnaireResponse.phase == phase,
        )
    return [q for q in db.scalars(query.order_by(QuestionnaireResponse.id)) if in_use(q)]


def check_questionnaire(
    db: Session,
    session_id: int,
    instrument: str,
    phase: str | None,
    change: Change,
    correction_of: int | None = None,
) -> tuple[StudySession, QuestionnaireResponse | None]:
    """The design's rules for one more entry; returns the session and the entry a correction replaces."""
    session = get_session(db, session_id)
    if session.excluded_at is not None:
        raise StateConflict(f"session {session_id} is excluded: it takes no questionnaires")
    what = _describe(instrument, phase)
    existing = _same_entries(db, session, instrument, phase)
    replaced: QuestionnaireResponse | None = None
    if correction_of is not None:
        replaced = db.get(QuestionnaireResponse, correction_of)
        if replaced is None:
            raise RecordNotFound(f"questionnaire entry {correction_of} not found")
        if replaced not in existing:
            state = "replaced or excluded" if not in_use(replaced) else f"not {what} of session {session_id}"
            raise StateConflict(f"entry {correction_of} is {state}: a correction replaces an entry in use")
        if not change.reason:
            raise StateConflict('a correction needs a "reason"')
    elif existing:
        first = existing[-1]
        where = "" if first.session_id == session_id else f" (in session {first.session_id})"
        raise StateConflict(
            f"session {session_id} already has {what}: entry {first.id}{where}, submitted "
            f"{first.created_at:%Y-%m-%d %H:%M:%S} UTC. To replace it, send a correction "
            f'("correction_of": {first.id} with a "reason")'
        )
    if instrument == "ssq" and phase == "pre" and session.started_at is not None and replaced is None:
        change.rule(
            "pre_after_start",
            f"session {session_id} is {session.status}: the SSQ before the session belongs before it starts",
        )
    if phase == "post" and session.started_at is None:
        change.rule(
            "not_started",
            f"session {session_id} has not started: {what} is filled in after the session has run",
        )
    return session, replaced


def add_questionnaire(
    db: Session,
    session_id: int,
    instrument: str,
    phase: str | None,
    answers: dict[str, Any],
    pairwise: dict[str, Any] | None,
    scores: dict[str, float],
    change: Change | None = None,
    correction_of: int | None = None,
    entered_by: str = "operator",
) -> QuestionnaireResponse:
    """Store a scored sheet (after :func:`check_questionnaire`'s rules); logs a ``questionnaire`` event."""
    change = change or Change()
    _session, replaced = check_questionnaire(db, session_id, instrument, phase, change, correction_of)
    row = QuestionnaireResponse(
        session_id=session_id,
        instrument=instrument,
        phase=phase,
        answers=answers,
        pairwise=pairwise,
        scores=scores,
        created_at=utcnow(),
        entered_by=entered_by,
        corrects_id=replaced.id if replaced is not None else None,
        correction_reason=change.reason if replaced is not None else None,
    )
    db.add(row)
    db.flush()
    payload: dict[str, Any] = {
        "id": row.id,
        "instrument": instrument,
        "phase": phase,
        "entered_by": entered_by,
    }
    if replaced is not None:
        before = questionnaire_dict(replaced)
        replaced.superseded_by_id = row.id
        _audit(db, change, "correct", "questionnaire", replaced.id, before, questionnaire_dict(row))
        payload.update(corrects=replaced.id, reason=change.reason)
    _log_overrides(db, change, "questionnaire", row.id, session_id)
    db.add(Event(session_id=session_id, ts=time.time(), kind="questionnaire", payload=payload))
    db.commit()
    return row


def list_questionnaires(db: Session, session_id: int) -> Sequence[QuestionnaireResponse]:
    get_session(db, session_id)
    return db.scalars(
        select(QuestionnaireResponse)
        .where(QuestionnaireResponse.session_id == session_id)
        .order_by(QuestionnaireResponse.id)
    ).all()


def get_questionnaire(db: Session, questionnaire_id: int) -> QuestionnaireResponse:
    row = db.get(QuestionnaireResponse, questionnaire_id)
    if row is None:
        raise RecordNotFound(f"questionnaire entry {questionnaire_id} not found")
    return row


def set_questionnaire_excluded(
    db: Session, questionnaire_id: int, excluded: bool, change: Change
) -> QuestionnaireResponse:
    row = get_questionnaire(db, questionnaire_id)
    if row.superseded_by_id is not None:
        raise StateConflict(f"entry {questionnaire_id} was replaced by entry {row.superseded_by_id}")
    if excluded == (row.excluded_at is not None):
        raise StateConflict(f"entry {questionnaire_id} is {'already' if excluded else 'not'} excluded")
    if not excluded:
        session = get_session(db, row.session_id)
        others = [q.id for q in _same_entries(db, session, row.instrument, row.phase) if q.id != row.id]
        if others:
            raise StateConflict(
                f"entry {', '.join(map(str, others))} is in use for {_describe(row.instrument, row.phase)}"
            )
    before = questionnaire_dict(row)
    row.excluded_at, row.exclusion_reason = (utcnow(), change.reason) if excluded else (None, None)
    _audit(
        db,
        change,
        "exclude" if excluded else "include",
        "questionnaire",
        row.id,
        before,
        questionnaire_dict(row),
    )
    db.add(
        Event(
            session_id=row.session_id,
            ts=time.time(),
            kind="correction",
            payload={
                "what": f"questionnaire {row.id} {'excluded' if excluded else 'included'}",
                "reason": change.reason,
                "by": change.actor,
            },
        )
    )
    db.commit()
    return row


# --- audit trail --------------------------------------------------------------------------


def list_audit(
    db: Session, entity: str | None = None, entity_id: int | None = None, limit: int = 1000
) -> Sequence[AuditEntry]:
    q = select(AuditEntry).order_by(AuditEntry.id.desc()).limit(limit)
    if entity is not None:
        q = q.where(AuditEntry.entity == entity)
    if entity_id is not None:
        q = q.where(AuditEntry.entity_id == entity_id)
    return db.scalars(q).all()


# --- participant links --------------------------------------------------------------------


def _digest(token: str) -> str:
    return hashlib.sha256(token.encode("utf-8", "surrogatepass")).hexdigest()


def create_participant_link(db: Session, session_id: int) -> tuple[ParticipantLink, str]:
    """A fresh credential for the session's participant page (earlier ones stop working)."""
    session = get_session(db, session_id)
    if session.excluded_at is not None:
        raise StateConflict(f"session {session_id} is excluded")
    now = utcnow()
    for old in db.scalars(
        select(ParticipantLink).where(
            ParticipantLink.session_id == session_id, ParticipantLink.revoked_at.is_(None)
        )
    ):
        old.revoked_at = now
    token = secrets.token_urlsafe(18)
    row = ParticipantLink(session_id=session_id, token_sha256=_digest(token), created_at=now)
    db.add(row)
    db.commit()
    return row, token


def session_for_link(db: Session, token: str) -> tuple[StudySession, ParticipantLink] | None:
    """The session a participant credential opens, or None (unknown, revoked, excluded)."""
    if not token or len(token) > 128:
        return None
    link = db.scalars(select(ParticipantLink).where(ParticipantLink.token_sha256 == _digest(token))).first()
    if link is None or link.revoked_at is not None:
        return None
    session = db.get(StudySession, link.session_id)
    if session is None or session.excluded_at is not None:
        return None
    return session, link


# --- planning the whole study -------------------------------------------------------------


def latin_square(conditions: Sequence[str]) -> list[list[str]]:
    """The cyclic Latin square of the conditions: row i starts with condition i (each condition once
    in each position); with two conditions: [CC, EC], [EC, CC]."""
    k = len(conditions)
    return [[conditions[(i + j) % k] for j in range(k)] for i in range(k)]


def plan_study(
    db: Session,
    n: int,
    code_prefix: str,
    first_number: int,
    planned_duration_s: float | None,
    first_conditions: Sequence[str] | None = None,
) -> list[tuple[Participant, list[str], list[StudySession]]]:
    """N participants, each with both sessions planned in a Latin-square order (rows taken in turn,
    starting where the enrolment so far leaves the groups balanced), or in the orders given."""
    if first_conditions is not None and len(first_conditions) != n:
        raise StateConflict(f"first_conditions lists {len(first_conditions)} conditions for {n} participants")
    square = latin_square(CONDITIONS)
    offset = CONDITIONS.index(next_first_condition(db))
    width = max(2, len(str(first_number + n - 1)))
    codes = [f"{code_prefix}{first_number + i:0{width}d}" for i in range(n)]
    taken = [c for c in codes if _same_code(db, c) is not None]
    if taken:
        raise StateConflict(f"participant code(s) {', '.join(taken)} already exist")
    out = []
    for i, code in enumerate(codes):
        order = (
            square[(offset + i) % len(square)]
            if first_conditions is None
            else next(r for r in square if r[0] == first_conditions[i])
        )
        p = Participant(code=code, first_condition=order[0], notes="", created_at=utcnow())
        db.add(p)
        db.flush()
        sessions = []
        for index, cond in enumerate(order, start=1):
            s = StudySession(
                participant_id=p.id,
                condition=cond,
                planned_index=index,
                status="planned",
                notes="",
                planned_duration_s=planned_duration_s,
                created_at=utcnow(),
            )
            db.add(s)
            sessions.append(s)
        out.append((p, list(order), sessions))
    db.flush()
    db.commit()
    return out
