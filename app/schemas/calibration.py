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
