"""Request and response models of questionnaire submissions.

An answer is a JSON integer on the instrument's scale (or MSSQ's ``"not_experienced"``): booleans,
numeric strings and fractions are refused (issue 15 D3).
"""

from __future__ import annotations

from datetime import datetime
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, StrictInt

from app.schemas.participants import MAX_ID, OverrideReason, StrictRequest
from app.schemas.text import Actor, Reason

Instrument = Literal["ssq", "mssq", "ipq", "nasa_tlx"]
Phase = Literal["pre", "post"]
Answer = StrictInt | Literal["not_experienced"]
ItemKey = Annotated[str, Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_]+$")]


class QuestionnaireCreate(StrictRequest):
    instrument: Instrument
    phase: Phase | None = Field(None, description="Required: pre or post (the instrument's phases).")
    answers: dict[ItemKey, Answer] = Field(max_length=64)
    pairwise: dict[ItemKey, str] | None = Field(
        None, max_length=64, description="NASA-TLX: all 15 comparisons or none."
    )
    correction_of: int | None = Field(
        None,
        ge=1,
        le=MAX_ID,
        description="The entry this one replaces (an explicit correction; needs a reason).",
    )
    reason: Reason | None = None
    by: Actor | None = None
    override_reason: OverrideReason = None


class ParticipantSubmission(StrictRequest):
    """What the participant page sends: the sheet only (no corrections, no overrides)."""

    instrument: Instrument
    phase: Phase
    answers: dict[ItemKey, Answer] = Field(max_length=64)
    pairwise: dict[ItemKey, str] | None = Field(None, max_length=64)


class QuestionnairePublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    session_id: int
    instrument: Instrument
    phase: Phase | None
    answers: dict[str, Any]
    pairwise: dict[str, Any] | None
    scores: dict[str, float]
    created_at: datetime
    entered_by: str = "operator"
    corrects_id: int | None = None
    correction_reason: str | None = None
    superseded_by_id: int | None = None
    excluded_at: datetime | None = None
    exclusion_reason: str | None = None
    in_use: bool = True


class AuditPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    at: datetime
    actor: str
    action: str
    entity: str
    entity_id: int
    before: dict[str, Any] | None
    after: dict[str, Any] | None
    reason: str
