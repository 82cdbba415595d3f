"""The live status of the pipeline (the same object the WebSocket sends)."""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import PipelineDep
from app.schemas.live import StatusPublic

router = APIRouter(tags=["status"])


@router.get("/status", response_model=StatusPublic)
def get_status(pipeline: PipelineDep) -> StatusPublic:
    return StatusPublic.model_validate(pipeline.snapshot())
