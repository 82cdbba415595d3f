"""Request and response models of participants (pseudonymous codes only)."""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from app.db.models import PARTICIPANT_CODE_PATTERN

Condition = Literal["CC", "EC"]
MAX_ID = 2**63 - 1  # SQLite INTEGER
ParticipantCode = Annotated[
    str,
    Field(
        pattern=PARTICIPANT_CODE_PATTERN,
        description="Pseudonymous code (letters, digits, _ and -; at most 32), never a name.",
        examples=["P01"],
    ),
]


class ParticipantCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")

    code: ParticipantCode
    first_condition: Condition | None = Field(
        None, description="Condition of the first session; omitted = counterbalanced automatically."
    )
    notes: str = Field("", max_length=10_000)


class ParticipantUpdate(BaseModel):
    model_config = ConfigDict(extra="forbid")

    first_condition: Condition | None = None
    notes: str | None = Field(None, max_length=10_000)


class ParticipantPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    code: str
    first_condition: Condition | None
    notes: str
    created_at: datetime
