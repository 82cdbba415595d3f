"""Request and response models of study sessions and their event log."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from app.schemas.participants import MAX_ID, Condition

SessionStatus = Literal["planned", "running", "stopped"]


class SessionCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")

    participant_id: int = Field(ge=1, le=MAX_ID)
    condition: Condition
    planned_index: Literal[1, 2] | None = Field(
        None, description="1 or 2 in the counterbalanced order; omitted = from the participant's order."
    )
    notes: str = Field("", max_length=10_000)


class SessionUpdate(BaseModel):
    model_config = ConfigDict(extra="forbid")

    notes: str = Field(max_length=10_000)


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


class EventPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    session_id: int | None
    ts: float = Field(description="Unix time, seconds.")
    kind: str
    payload: dict[str, Any]
