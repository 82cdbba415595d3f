"""Response models of the study design and analysis endpoints (``app.study``)."""

from __future__ import annotations

from typing import Any, Literal

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
    p_adjusted: float | None = None
    normality_note: str | None = None
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
    correction: Literal["holm", "bonferroni", "none"] = "holm"
    correction_text: str = ""
    exclusions: list[dict[str, Any]] = Field(default_factory=list, description="Excluded by the operator.")
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
    completed_participants: int = Field(description="Participants who ran both conditions (not excluded).")
    incomplete: list[str] = Field(description="Codes of participants who have not run both conditions.")
    first_condition_counts: dict[str, int] = Field(description="Over the participants who completed both.")
    enrolled_first_condition_counts: dict[str, int]
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


class ParticipantLinkPublic(BaseModel):
    """The participant page's link for one session (its credential opens that session only)."""

    session_id: int
    url: str
    qr_svg: str = Field(description="The link as a QR code (SVG).")
    reachable_from_lan: bool = Field(
        description="False when the server listens on loopback only: a tablet cannot open the link."
    )


class ScriptStepPublic(BaseModel):
    model_config = ConfigDict(extra="allow")

    key: str
    label: str
    kind: Literal["questionnaire", "run"]
    instrument: str | None = None
    phase: str | None = None
    state: Literal["done", "current", "todo", "running"]


class SessionScriptPublic(BaseModel):
    session_id: int
    status: str
    condition: Condition
    steps: list[ScriptStepPublic]
    current: str | None
    complete: bool


class SessionSummaryPublic(BaseModel):
    session_id: int
    status: str
    duration_s: float | None
    without_navigator_s: float | None = Field(description="Time the session ran with nobody steering.")
    without_navigator_fraction: float | None
    held_s: float | None = Field(None, description="Time the operator held navigation (the walls got still).")
    holds: int = Field(0, description="Times the operator held navigation during the session.")
    locomotion_alarms: int = Field(description="Times no locomotion command went out for more than 2 s.")
    locomotion_gap_s: float
    navigator_changes: int
    actions_s: dict[str, float]
    questionnaires: int
    corrections: int
    overrides: int
    stopped_by: str | None


class PlanRequest(BaseModel):
    """Plan the whole study at once: N participants, each with both sessions, orders from a Latin square."""

    model_config = ConfigDict(extra="forbid", strict=True)

    participants: int = Field(ge=1, le=500)
    code_prefix: str = Field("P", pattern=r"^[A-Za-z][A-Za-z0-9_-]{0,20}$")
    first_number: int = Field(1, ge=0, le=100_000)
    run_minutes: float | None = Field(10.0, gt=0, le=240, description="The session script's run time.")
    first_conditions: list[Condition] | None = Field(
        None, description="Override: each participant's first condition instead of the Latin square's."
    )


class PlannedParticipant(BaseModel):
    participant_id: int
    code: str
    order: list[Condition]
    session_ids: list[int]


class PlanPublic(BaseModel):
    participants: list[PlannedParticipant]
    latin_square: list[list[Condition]]
    overridden: bool
