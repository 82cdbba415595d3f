"""Request and response models of takes and protocols."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from app.schemas.participants import MAX_ID, ParticipantCode, StrictRequest
from app.schemas.text import Notes

TakeStatus = Literal["recording", "complete", "incomplete"]


class TakeCreate(StrictRequest):
    participant_code: ParticipantCode | None = None
    session_id: int | None = Field(None, ge=1, le=MAX_ID, description="The study session it belongs to.")
    protocol: str | None = Field(None, max_length=64, description="A shipped protocol (GET /protocols).")
    protocol_toml: str | None = Field(None, max_length=20000, description="Or a protocol's TOML text.")
    duration_s: float | None = Field(None, gt=0, description="Default: the protocol's length.")
    margin_s: float | None = Field(None, description="Reaction margin after each label change, [0, 5] s.")
    lead_s: float | None = Field(None, description="Margin before each label change, [0, 5] s.")
    notes: Notes = ""
    videos: bool = Field(False, description="Also one MP4 per camera (cameras or video files only).")


class TakePublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    uid: str
    status: TakeStatus
    participant_code: str | None
    session_id: int | None
    protocol: str | None
    source: str | None
    started_at: datetime
    ended_at: datetime | None
    duration_s: float | None
    frames: int
    margin_s: float | None
    calibration_run_id: int | None
    files: dict[str, Any]
    notes: str


class PromptPublic(BaseModel):
    index: int
    steps: int
    text: str
    label: str
    tag: str
    remaining_s: float
    next: str | None


class VideoStatsPublic(BaseModel):
    """One camera's video while a take records: frames written, dropped (the encoder was behind)."""

    state: str
    written: int
    dropped: int
    error: str | None = None
    files: int = 0


class RecordingPublic(BaseModel):
    """The take being recorded (``recording`` false and the rest null when none is)."""

    recording: bool
    take_id: int | None = None
    uid: str | None = None
    elapsed_s: float | None = None
    duration_s: float | None = None
    frames: int | None = None
    dropped: int | None = None
    videos: dict[str, VideoStatsPublic] | None = None
    protocol: str | None = None
    prompt: PromptPublic | None = None


class ProtocolStep(BaseModel):
    what: str
    duration_s: float
    label: str
    text: str
    tag: str


class ProtocolPublic(BaseModel):
    name: str
    file: str
    description: str
    duration_s: float
    steps: list[ProtocolStep]


class LabelSpanIn(StrictRequest):
    t_start: float = Field(ge=0)
    t_end: float = Field(gt=0)
    label: str = Field(max_length=16, description="still, forward, left, right or ignore")
    user_id: int | None = Field(None, ge=0, le=MAX_ID, description="null: the navigator at each frame")
    tag: str = Field("", max_length=64)
    source: str = Field("operator", max_length=16)


class LabelsUpdate(StrictRequest):
    spans: list[LabelSpanIn] = Field(max_length=5000)


class LabelsPublic(BaseModel):
    take_id: int
    duration_s: float | None
    spans: list[dict[str, Any]]


class ReplayRequest(StrictRequest):
    t_s: float = Field(ge=0, le=86400, description="Seconds into the take.")


class ReplayPublic(BaseModel):
    """The take's frame the 3D view now shows: the last captured at or before ``t_s``."""

    take_id: int
    t_s: float
    frame_t_s: float
    frame: int | None
    index: int
    users: list[int]
    navigator: int | None
