"""Request and response models of participants (pseudonymous codes only).

Requests are strict (issue 15 D3): ids and numbers are JSON numbers, never booleans or strings.
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

from app.db.models import PARTICIPANT_CODE_PATTERN
from app.schemas.text import Actor, Notes, Reason

Condition = Literal["CC", "EC"]
MAX_ID = 2**63 - 1  # SQLite INTEGER
ParticipantCode = Annotated[
    str,
    Field(
        pattern=PARTICIPANT_CODE_PATTERN,
        description="Pseudonymous code (letters, digits, _ and -; at most 32), never a name. "
        "Codes are unique ignoring case.",
        examples=["P01"],
    ),
]
OverrideReason = Annotated[
    Reason | None,
    Field(description="Record the request although it breaks a rule of the study design; why (logged)."),
]


class StrictRequest(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class ParticipantCreate(StrictRequest):
    code: ParticipantCode
    first_condition: Condition | None = Field(
        None, description="Condition of the first session; omitted = counterbalanced automatically."
    )
    notes: Notes = ""


class ParticipantUpdate(StrictRequest):
    first_condition: Condition | None = None
    notes: Notes | None = None
    code: ParticipantCode | None = Field(None, description="A corrected code (needs a reason).")
    reason: Reason | None = None
    by: Actor | None = None
    override_reason: OverrideReason = None


class ExclusionRequest(StrictRequest):
    """Exclude a record from the analysis (or include it again, or delete it), with a reason."""

    reason: Reason
    by: Actor | None = None


class ParticipantPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    code: str
    first_condition: Condition | None
    notes: str
    created_at: datetime
    excluded_at: datetime | None = None
    exclusion_reason: str | None = None
