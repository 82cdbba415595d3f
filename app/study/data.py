"""The study's records as plain frozen data, read once from the database.

Design, analysis and figures work on :class:`StudyData` only, so they are pure and testable
without a database; :func:`load_study` is the one place that reads the ORM models.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from app.db.models import Event, Participant, QuestionnaireResponse, StudySession

CONDITIONS: tuple[str, str] = ("CC", "EC")


@dataclass(frozen=True, slots=True)
class ParticipantRecord:
    id: int
    code: str
    first_condition: str | None = None
    excluded_reason: str | None = None  # set when the operator excluded the participant

    def __post_init__(self) -> None:
        if self.first_condition not in (None, *CONDITIONS):
            raise ValueError(f"first_condition must be CC, EC or None, got {self.first_condition!r}")


@dataclass(frozen=True, slots=True)
class SessionRecord:
    id: int
    participant_id: int
    condition: str
    planned_index: int | None = None
    status: str = "planned"
    started_at: datetime | None = None
    stopped_at: datetime | None = None
    excluded_reason: str | None = None

    def __post_init__(self) -> None:
        if self.condition not in CONDITIONS:
            raise ValueError(f"condition must be one of {CONDITIONS}, got {self.condition!r}")


@dataclass(frozen=True, slots=True)
class ResponseRecord:
    """One submitted questionnaire with its stored scores."""

    id: int
    session_id: int
    instrument: str
    phase: str | None
    answers: Mapping[str, Any]
    scores: Mapping[str, float]
    created_at: datetime | None = None
    pairwise: Mapping[str, str] | None = None  # NASA-TLX's 15 choices, when given
    superseded_by: int | None = None  # replaced by this entry (an explicit correction)
    excluded_reason: str | None = None
    corrects: int | None = None
    entered_by: str = "operator"

    @property
    def in_use(self) -> bool:
        return self.superseded_by is None and self.excluded_reason is None


@dataclass(frozen=True, slots=True)
class EventRecord:
    ts: float  # unix seconds
    kind: str
    payload: Mapping[str, Any]


@dataclass(frozen=True, slots=True)
class StudyData:
    participants: tuple[ParticipantRecord, ...] = ()
    sessions: tuple[SessionRecord, ...] = ()
    responses: tuple[ResponseRecord, ...] = ()
    _by_id: dict[int, ParticipantRecord] = field(default_factory=dict, compare=False, repr=False)

    def __post_init__(self) -> None:
        ids = {p.id for p in self.participants}
        for s in self.sessions:
            if s.participant_id not in ids:
                raise ValueError(f"session {s.id}: unknown participant_id {s.participant_id}")
        session_ids = {s.id for s in self.sessions}
        for r in self.responses:
            if r.session_id not in session_ids:
                raise ValueError(f"questionnaire {r.id}: unknown session_id {r.session_id}")
        self._by_id.update({p.id: p for p in self.participants})

    def participant(self, participant_id: int) -> ParticipantRecord:
        return self._by_id[participant_id]

    def sessions_of(self, participant_id: int) -> list[SessionRecord]:
        return [s for s in self.sessions if s.participant_id == participant_id]

    def responses_of(self, session_id: int) -> list[ResponseRecord]:
        return [r for r in self.responses if r.session_id == session_id]

    def why_not_used(self, r: ResponseRecord) -> str | None:
        """Why an entry is left out of the analysis (None: it is used)."""
        session = next(s for s in self.sessions if s.id == r.session_id)
        participant = self.participant(session.participant_id)
        if participant.excluded_reason is not None:
            return f"participant excluded: {participant.excluded_reason}"
        if session.excluded_reason is not None:
            return f"session excluded: {session.excluded_reason}"
        if r.superseded_by is not None:
            return f"replaced by entry {r.superseded_by}"
        if r.excluded_reason is not None:
            return f"entry excluded: {r.excluded_reason}"
        return None

    def analysed(self) -> StudyData:
        """Only what the analysis uses: participants, sessions and entries not excluded or replaced."""
        participants = tuple(p for p in self.participants if p.excluded_reason is None)
        kept = {p.id for p in participants}
        sessions = tuple(s for s in self.sessions if s.participant_id in kept and s.excluded_reason is None)
        ids = {s.id for s in sessions}
        responses = tuple(r for r in self.responses if r.session_id in ids and r.in_use)
        return StudyData(participants, sessions, responses)

    def exclusions(self) -> list[dict[str, Any]]:
        """Everything the operator excluded, with the reason (what the analysis lists)."""
        out: list[dict[str, Any]] = []
        for p in self.participants:
            if p.excluded_reason is not None:
                out.append({"kind": "participant", "code": p.code, "id": p.id, "reason": p.excluded_reason})
        for s in self.sessions:
            if s.excluded_reason is not None:
                code = self.participant(s.participant_id).code
                out.append({"kind": "session", "code": code, "id": s.id, "condition": s.condition,
                            "reason": s.excluded_reason})
        for r in self.responses:
            if r.excluded_reason is not None:
                session = next(s for s in self.sessions if s.id == r.session_id)
                out.append({"kind": "questionnaire", "code": self.participant(session.participant_id).code,
                            "id": r.id, "session_id": r.session_id, "instrument": r.instrument,
                            "phase": r.phase, "reason": r.excluded_reason})
        return out


def load_study(db: Session) -> StudyData:
    """Every participant, session and questionnaire of the database, ordered by id."""
    participants = tuple(
        ParticipantRecord(p.id, p.code, p.first_condition, _reason(p.excluded_at, p.exclusion_reason))
        for p in db.scalars(select(Participant).order_by(Participant.id))
    )
    sessions = tuple(
        SessionRecord(
            s.id, s.participant_id, s.condition, s.planned_index, s.status, s.started_at, s.stopped_at,
            _reason(s.excluded_at, s.exclusion_reason),
        )
        for s in db.scalars(select(StudySession).order_by(StudySession.id))
    )
    responses = tuple(
        ResponseRecord(
            r.id,
            r.session_id,
            r.instrument,
            r.phase,
            dict(r.answers),
            dict(r.scores),
            r.created_at,
            dict(r.pairwise) if r.pairwise is not None else None,
            r.superseded_by_id,
            _reason(r.excluded_at, r.exclusion_reason),
            r.corrects_id,
            r.entered_by,
        )
        for r in db.scalars(select(QuestionnaireResponse).order_by(QuestionnaireResponse.id))
    )
    return StudyData(participants, sessions, responses)


def _reason(excluded_at: datetime | None, reason: str | None) -> str | None:
    return None if excluded_at is None else (reason or "no reason given")


def load_events(db: Session, session_id: int, kind: str | None = None) -> list[EventRecord]:
    """The event log of one study session, oldest first (optionally one kind only)."""
    query = select(Event).where(Event.session_id == session_id)
    if kind is not None:
        query = query.where(Event.kind == kind)
    return [EventRecord(e.ts, e.kind, dict(e.payload or {})) for e in db.scalars(query.order_by(Event.ts))]
