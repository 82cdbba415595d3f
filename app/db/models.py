"""The typed SQLAlchemy 2 ORM models of cavewalk's SQLite database.

The schema is fixed (other modules, e.g. ``app.study``, read these classes);
columns are only ever added through a new Alembic migration in ``migrations/``.
Times are stored as UTC datetimes, except :attr:`Event.ts` (unix seconds, float)
which the pipeline's events carry.
"""

from __future__ import annotations

from datetime import UTC, datetime
from typing import Any

from sqlalchemy import JSON, Boolean, DateTime, Float, ForeignKey, Index, Integer, String, Text, func
from sqlalchemy.orm import DeclarativeBase, Mapped, mapped_column, relationship
from sqlalchemy.types import TypeDecorator

PARTICIPANT_CODE_PATTERN = r"^[A-Za-z0-9_-]{1,32}$"
CONDITIONS = ("CC", "EC")
SESSION_STATUSES = ("planned", "running", "stopped")
INSTRUMENTS = ("ssq", "mssq", "ipq", "nasa_tlx")
PHASES = ("pre", "post")
CALIBRATION_STATUSES = ("pending", "running", "done", "failed")
#: Who made a change in the audit trail: the operator (dashboard/API) or a participant link.
AUDIT_ACTIONS = ("create", "correct", "exclude", "include", "delete", "override", "update")


def utcnow() -> datetime:
    return datetime.now(UTC)


class UTCDateTime(TypeDecorator[datetime]):
    """A DateTime that is always timezone-aware UTC in Python (SQLite stores it naive)."""

    impl = DateTime
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Any) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is None:
            value = value.replace(tzinfo=UTC)
        return value.astimezone(UTC).replace(tzinfo=None)

    def process_result_value(self, value: datetime | None, dialect: Any) -> datetime | None:
        return None if value is None else value.replace(tzinfo=UTC)


class Base(DeclarativeBase):
    pass


class Participant(Base):
    """A pseudonymous study participant (the code is the only identifier stored)."""

    __tablename__ = "participants"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    code: Mapped[str] = mapped_column(String(32), unique=True, nullable=False)
    first_condition: Mapped[str | None] = mapped_column(String(2), nullable=True)  # "CC" | "EC"
    notes: Mapped[str] = mapped_column(Text, default="", nullable=False)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    excluded_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    exclusion_reason: Mapped[str | None] = mapped_column(Text, nullable=True)

    sessions: Mapped[list[StudySession]] = relationship(
        back_populates="participant", order_by="StudySession.id"
    )

    # p01 and P01 are one participant: codes are unique ignoring case
    __table_args__ = (Index("ix_participants_code_nocase", func.upper(code), unique=True),)


class StudySession(Base):
    """One participant's block in one condition ("CC" controller / "EC" embodied)."""

    __tablename__ = "study_sessions"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    participant_id: Mapped[int] = mapped_column(ForeignKey("participants.id"), nullable=False, index=True)
    condition: Mapped[str] = mapped_column(String(2), nullable=False)
    planned_index: Mapped[int | None] = mapped_column(Integer, nullable=True)  # 1 or 2
    status: Mapped[str] = mapped_column(String(16), default="planned", nullable=False)
    started_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    stopped_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    notes: Mapped[str] = mapped_column(Text, default="", nullable=False)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    #: the session script's run time (None = stopped by hand); the server stops the session after it
    planned_duration_s: Mapped[float | None] = mapped_column(Float, nullable=True)
    stopped_by: Mapped[str | None] = mapped_column(String(16), nullable=True)  # operator | timer
    excluded_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    exclusion_reason: Mapped[str | None] = mapped_column(Text, nullable=True)

    participant: Mapped[Participant] = relationship(back_populates="sessions")
    questionnaires: Mapped[list[QuestionnaireResponse]] = relationship(
        back_populates="session", order_by="QuestionnaireResponse.id"
    )


class QuestionnaireResponse(Base):
    """A submitted questionnaire: the raw answers and the scores computed on submission."""

    __tablename__ = "questionnaire_responses"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("study_sessions.id"), nullable=False, index=True)
    instrument: Mapped[str] = mapped_column(String(16), nullable=False)
    phase: Mapped[str | None] = mapped_column(String(8), nullable=True)
    answers: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)
    pairwise: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    scores: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    #: "operator" (the dashboard's form or the API) or "participant" (the session's participant link)
    entered_by: Mapped[str] = mapped_column(String(16), default="operator", nullable=False)
    #: an explicit correction replaces an earlier entry (kept, marked superseded) and says why
    corrects_id: Mapped[int | None] = mapped_column(
        ForeignKey("questionnaire_responses.id"), nullable=True
    )
    correction_reason: Mapped[str | None] = mapped_column(Text, nullable=True)
    superseded_by_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    excluded_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    exclusion_reason: Mapped[str | None] = mapped_column(Text, nullable=True)

    session: Mapped[StudySession] = relationship(back_populates="questionnaires")


class Event(Base):
    """One entry of the event log (action, navigator, calibration, pipeline, session, error ...)."""

    __tablename__ = "events"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int | None] = mapped_column(ForeignKey("study_sessions.id"), nullable=True, index=True)
    ts: Mapped[float] = mapped_column(Float, nullable=False)  # unix seconds
    kind: Mapped[str] = mapped_column(String(32), nullable=False)
    payload: Mapped[dict[str, Any]] = mapped_column(JSON, nullable=False, default=dict)

    __table_args__ = (Index("ix_events_ts", "ts"),)


class AuditEntry(Base):
    """One change to the study's records: who, when, what (before and after) and why."""

    __tablename__ = "audit_log"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    actor: Mapped[str] = mapped_column(String(64), nullable=False)
    action: Mapped[str] = mapped_column(String(16), nullable=False)
    entity: Mapped[str] = mapped_column(String(16), nullable=False)  # participant | session | questionnaire
    entity_id: Mapped[int] = mapped_column(Integer, nullable=False)
    before: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    after: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    reason: Mapped[str] = mapped_column(Text, default="", nullable=False)

    __table_args__ = (Index("ix_audit_log_entity", "entity", "entity_id"),)


class ParticipantLink(Base):
    """A per-session credential for the participant's tablet (only its SHA-256 is stored)."""

    __tablename__ = "participant_links"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    session_id: Mapped[int] = mapped_column(ForeignKey("study_sessions.id"), nullable=False, index=True)
    token_sha256: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    revoked_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)


class CalibrationRun(Base):
    """A calibration of the cameras: its progress, its result and whether it is the active one."""

    __tablename__ = "calibration_runs"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    status: Mapped[str] = mapped_column(String(16), default="pending", nullable=False)
    progress: Mapped[float] = mapped_column(Float, default=0.0, nullable=False)
    message: Mapped[str] = mapped_column(Text, default="", nullable=False)
    result: Mapped[dict[str, Any] | None] = mapped_column(JSON, nullable=True)
    active: Mapped[bool] = mapped_column(Boolean, default=False, nullable=False)


TAKE_STATUSES = ("recording", "complete", "incomplete")


class Take(Base):
    """A recorded take (SPEC.md "Takes"): its folder in the takes data folder and what it holds.

    ``uid`` is the take's folder name and the id in its ``take.json``; ``files`` maps each file
    name to its bytes and sha256; ``status`` is ``recording`` until it ends, then ``complete``,
    or ``incomplete`` when the server stopped during it and the next start recovered it.
    """

    __tablename__ = "takes"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    uid: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    folder: Mapped[str] = mapped_column(Text, nullable=False)
    status: Mapped[str] = mapped_column(String(16), default="recording", nullable=False)
    participant_code: Mapped[str | None] = mapped_column(String(32), nullable=True, index=True)
    session_id: Mapped[int | None] = mapped_column(ForeignKey("study_sessions.id"), nullable=True, index=True)
    protocol: Mapped[str | None] = mapped_column(String(64), nullable=True)
    source: Mapped[str | None] = mapped_column(String(16), nullable=True)
    started_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    ended_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    duration_s: Mapped[float | None] = mapped_column(Float, nullable=True)
    frames: Mapped[int] = mapped_column(Integer, default=0, nullable=False)
    margin_s: Mapped[float | None] = mapped_column(Float, nullable=True)
    calibration_run_id: Mapped[int | None] = mapped_column(Integer, nullable=True)
    files: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict, nullable=False)
    notes: Mapped[str] = mapped_column(Text, default="", nullable=False)


MODEL_KINDS = ("base", "trained", "uploaded")


class ActionModel(Base):
    """An action model in the registry: its file in the models data folder and its card.

    ``kind``: ``base`` (the committed model, always present), ``trained`` (``cavewalk train``) or
    ``uploaded``; ``card`` holds the file's checked metadata and the training figures, ``card_md``
    the model card as Markdown. One row is ``active``; ``activated_at`` orders the roll-backs.
    """

    __tablename__ = "action_models"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    uid: Mapped[str] = mapped_column(String(64), unique=True, nullable=False)
    name: Mapped[str] = mapped_column(String(128), nullable=False)
    kind: Mapped[str] = mapped_column(String(16), nullable=False)
    file: Mapped[str] = mapped_column(Text, nullable=False)
    sha256: Mapped[str] = mapped_column(String(64), nullable=False)
    parent_id: Mapped[int | None] = mapped_column(ForeignKey("action_models.id"), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    active: Mapped[bool] = mapped_column(Boolean, default=False, nullable=False)
    activated_at: Mapped[datetime | None] = mapped_column(UTCDateTime(), nullable=True)
    card: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict, nullable=False)
    card_md: Mapped[str] = mapped_column(Text, default="", nullable=False)
    notes: Mapped[str] = mapped_column(Text, default="", nullable=False)


class Adaptation(Base):
    """A participant's teach adaptation of one action model (applies to their sessions only)."""

    __tablename__ = "adaptations"

    id: Mapped[int] = mapped_column(Integer, primary_key=True)
    participant_code: Mapped[str] = mapped_column(String(32), nullable=False, index=True)
    model_id: Mapped[int] = mapped_column(ForeignKey("action_models.id"), nullable=False)
    take_id: Mapped[int | None] = mapped_column(ForeignKey("takes.id"), nullable=True)
    created_at: Mapped[datetime] = mapped_column(UTCDateTime(), default=utcnow, nullable=False)
    enabled: Mapped[bool] = mapped_column(Boolean, default=True, nullable=False)
    method: Mapped[str] = mapped_column(String(32), nullable=False)
    params: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict, nullable=False)
    report: Mapped[dict[str, Any]] = mapped_column(JSON, default=dict, nullable=False)


__all__ = [
    "AUDIT_ACTIONS",
    "CALIBRATION_STATUSES",
    "CONDITIONS",
    "INSTRUMENTS",
    "MODEL_KINDS",
    "PARTICIPANT_CODE_PATTERN",
    "PHASES",
    "SESSION_STATUSES",
    "TAKE_STATUSES",
    "ActionModel",
    "Adaptation",
    "AuditEntry",
    "Base",
    "CalibrationRun",
    "Event",
    "Participant",
    "ParticipantLink",
    "QuestionnaireResponse",
    "StudySession",
    "Take",
    "utcnow",
]
