"""Request and response models of camera-coverage plans."""

from __future__ import annotations

from datetime import datetime
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field

PlanStatus = Literal["pending", "running", "done", "failed"]
PlanSource = Literal["active", "default", "proposed", "search"]


class PlanCreate(BaseModel):
    """What to plan: a camera set (``active`` calibration, the simulator's ``default`` layout, a
    ``proposed`` set in calibration JSON) or a mount ``search`` for ``count`` cameras."""

    model_config = ConfigDict(extra="forbid")

    source: PlanSource = Field("active", description="Which cameras to map, or 'search' for new mounts.")
    calibration: dict[str, Any] | None = Field(
        None, description="source 'proposed': the cameras, as the calibration JSON of SPEC.md."
    )
    count: int | None = Field(None, ge=2, le=16, description="source 'search': how many cameras to place.")
    grid_step_m: float | None = Field(
        None, ge=0.1, le=1.0, description="Floor cell side (default: settings)."
    )
    samples: int | None = Field(None, ge=1, le=16, description="Monte Carlo draws per cell and pose.")
    seed: int | None = Field(None, ge=0, le=2**31 - 1)
    top_k: int | None = Field(None, ge=1, le=5, description="source 'search': best layouts to map.")


class PlanJobAccepted(BaseModel):
    id: int
    status: PlanStatus
    status_url: str


class PlanJobPublic(BaseModel):
    id: int
    created_at: datetime
    source: str
    status: PlanStatus
    progress: float
    message: str
    elapsed_s: float | None = None
    figures: list[str] = Field(default_factory=list, description="Figure URLs (PNG and SVG), when done.")
    result: dict[str, Any] | None = Field(
        None, description="The plan's numbers (as cavewalk plan's plan.json)."
    )
