"""Response models of calibration runs."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

CalibrationStatus = Literal["pending", "running", "done", "failed"]


class CalibrationCameraPublic(BaseModel):
    name: str
    rms_px: float | None = None
    verdict: str | None = None
    markers_used: int | None = None
    walls_seen: list[str] = Field(default_factory=list)


class CalibrationRunPublic(BaseModel):
    model_config = ConfigDict(from_attributes=True)

    id: int
    created_at: datetime
    status: CalibrationStatus
    progress: float
    message: str
    active: bool
    cameras: list[CalibrationCameraPublic] = Field(default_factory=list)
    result: dict[str, Any] | None = None


class CalibrationJobAccepted(BaseModel):
    id: int
    status: CalibrationStatus
    status_url: str


class CameraFigures(BaseModel):
    rms_px: float | None = None
    verdict: str | None = None
    markers_used: int | None = None
    walls_seen: list[str] = Field(default_factory=list)
    coverage: float | None = None


class CameraComparison(BaseModel):
    name: str
    new: CameraFigures
    active: CameraFigures | None = Field(description="The active run's figures (None: no active run).")
    moved_m: float | None = Field(description="How far the camera's centre moved from the active run's.")
    turned_deg: float | None = Field(description="How far its orientation turned.")


class CalibrationComparePublic(BaseModel):
    run_id: int
    active_id: int | None
    accepted: bool
    cameras: list[CameraComparison]
