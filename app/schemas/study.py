"""Response models of the study design and analysis endpoints (``app.study``)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

Condition = Literal["CC", "EC"]


class MeasurePublic(BaseModel):
    """One measure's paired comparison (EC - CC). ``test`` is None when there is not enough data."""

    model_config = ConfigDict(extra="allow")

    n: int
    test: Literal["paired_t", "wilcoxon"] | None
    statistic: float | None
    p: float | None
    cohens_d: float | None
    cohens_d_ci95: list[float] | None = None
    effect_label: str | None
    normal: bool | None
    mean_cc: float | None
    sd_cc: float | None
    mean_ec: float | None
    sd_ec: float | None
    note: str | None = None


class AnalysisPublic(BaseModel):
    model_config = ConfigDict(extra="allow")

    participants: int = Field(description="Registered participants.")
    excluded: list[str] = Field(description="Codes of participants left out of the paired tests.")
    excluded_reasons: dict[str, str] = {}
    measures: dict[str, MeasurePublic]


class GapWarningPublic(BaseModel):
    participant_id: int
    code: str
    session_ids: list[int]
    gap_days: float
    min_gap_days: float
    message: str


class MissingQuestionnaire(BaseModel):
    session_id: int | None
    condition: Condition | None
    instrument: str
    phase: str | None


class CompletenessPublic(BaseModel):
    participant_id: int
    code: str
    sessions: int
    missing_conditions: list[Condition]
    missing: list[MissingQuestionnaire]
    complete: bool


class DesignPublic(BaseModel):
    participants: int
    first_condition_counts: dict[str, int]
    balanced: bool = Field(description="The CC-first and EC-first groups differ by at most one.")
    next_first_condition: Condition
    next_order: list[Condition]
    min_gap_days: float
    gap_warnings: list[GapWarningPublic]
    completeness: list[CompletenessPublic]


class OrderPublic(BaseModel):
    participant: int = Field(description="1-based position in the order of enrolment.")
    order: list[Condition]


class InstrumentItem(BaseModel):
    key: str
    text: str
    anchors: list[str]
    min: int
    max: int
    allow: list[str]


class InstrumentPair(BaseModel):
    key: str
    options: list[str]


class InstrumentPublic(BaseModel):
    name: str
    title: str
    instructions: str
    phases: list[Literal["pre", "post"] | None]
    score_keys: list[str]
    items: list[InstrumentItem]
    pairs: list[InstrumentPair]
