"""Request and response models of the action-model registry, training jobs and teach adaptations."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, Field

from app.schemas.participants import MAX_ID, StrictRequest
from app.schemas.text import Notes

ModelKind = Literal["base", "trained", "uploaded"]


class ModelPublic(BaseModel):
    id: int
    uid: str
    name: str
    kind: ModelKind
    sha256: str
    parent_id: int | None
    created_at: datetime
    active: bool
    activated_at: datetime | None
    card: dict[str, Any]
    notes: str


class ModelUpload(StrictRequest):
    """A model file sent as base64 (the API takes JSON only), with its card."""

    name: str = Field(min_length=1, max_length=128, pattern=r"^[^\x00-\x1f]+$")
    onnx_base64: str = Field(
        min_length=1,
        max_length=15_000_000,
        description="The ONNX file, base64 (up to ~11 MB; the request up to server.max_model_bytes).",
    )
    card: dict[str, Any] | None = Field(
        None,
        description="The model card's figures; window, fps, classes, features, sha256 must match the file.",
    )
    card_md: str = Field("", max_length=100_000, description="The model card as Markdown.")
    notes: Notes = ""


class TrainCreate(StrictRequest):
    take_ids: list[int] = Field(min_length=1, max_length=200, description="Labelled takes to fine-tune on.")
    epochs: int = Field(2, ge=1, le=50)
    sim_routines: int = Field(8, ge=0, le=400, description="Simulated routines added to the takes.")
    sim_duration_s: float = Field(12.0, ge=4, le=120, description="Seconds per simulated routine.")
    windows_per_epoch: int = Field(4096, ge=256, le=100_000)
    heldout_routines: int = Field(2, ge=0, le=100, description="Simulated test routines (another seed).")
    loso: bool = Field(
        True, description="Leave-one-participant-out figures (one more fine-tune per participant)."
    )
    activate: bool = Field(False, description="Activate the new model when it is registered.")


class TrainJobPublic(BaseModel):
    id: int
    state: Literal["running", "done", "failed"]
    progress: float
    message: str
    log: list[str]
    model_id: int | None
    started_at: datetime
    ended_at: datetime | None


class TeachCreate(StrictRequest):
    take_id: int = Field(ge=1, le=MAX_ID, description="The participant's recorded teach take.")
    holdout_fraction: float = Field(0.34, ge=0.1, le=0.6)


class AdaptationPublic(BaseModel):
    id: int
    participant_code: str
    model_id: int
    take_id: int | None
    created_at: datetime
    enabled: bool
    method: str
    report: dict[str, Any]


class AdaptationUpdate(StrictRequest):
    enabled: bool
