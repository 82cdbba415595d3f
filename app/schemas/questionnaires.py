"""Request and response models of questionnaire submissions."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

Instrument = Literal["ssq", "mssq", "ipq", "nasa_tlx"]
Phase = Literal["pre", "post"]


class QuestionnaireCreate(BaseModel):
    model_config = ConfigDict(extra="forbid")

    instrument: Instrument
    phase: Phase | None = None
    answers: dict[str, int | float | str] = Field(max_length=64)
    pairwise: dict[str, str] | None = Field(None, max_length=64)


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
