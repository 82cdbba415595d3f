"""Request and response models of study sessions and their event log."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictInt

from app.schemas.participants import MAX_ID, Condition, OverrideReason, StrictRequest
from app.schemas.text import Notes

SessionStatus = Literal["planned", "running", "stopped"]


class SessionCreate(StrictRequest):
    participant_id: StrictInt = Field(ge=1, le=MAX_ID)
    condition: Condition
    planned_index: StrictInt | None = Field(
        None,
        ge=1,
        le=2,
        description="1 or 2 in the counterbalanced order; omitted = from the participant's order.",
    )
    planned_duration_s: float | None = Field(
        None, ge=5, le=4 * 3600, description="Run time of the session script: the server stops it then."
    )
    notes: Notes = ""
    override_reason: OverrideReason = None


class SessionUpdate(StrictRequest):
    notes: Notes | None = None
    planned_duration_s: float | None = Field(None, ge=5, le=4 * 3600)


class SessionPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    participant_id: int
    participant_code: str | None = None
    condition: Condition
    planned_index: int | None
    status: SessionStatus
    started_at: datetime | None
    stopped_at: datetime | None
    notes: str
    created_at: datetime
    planned_duration_s: float | None = None
    stopped_by: str | None = None
    duration_s: float | None = Field(None, description="Run time of a stopped session, seconds.")
    excluded_at: datetime | None = None
    exclusion_reason: str | None = None


class EventPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    session_id: int | None
    ts: float = Field(description="Unix time, seconds.")
    kind: str
    payload: dict[str, Any]
