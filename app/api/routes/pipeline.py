"""Start and stop the recognition pipeline and choose its source."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, HTTPException, status

from app.api.deps import PipelineDep
from app.schemas.live import PipelineStart, StatusPublic
from app.services.live import PipelineUnavailable
from pipeline.errors import CavewalkError

router = APIRouter(prefix="/pipeline", tags=["pipeline"])


@router.get("", response_model=StatusPublic)
def pipeline_status(pipeline: PipelineDep) -> StatusPublic:
    return StatusPublic.model_validate(pipeline.snapshot())


@router.post("/start", response_model=StatusPublic)
def start(body: PipelineStart, pipeline: PipelineDep) -> StatusPublic:
    videos = None
    if body.videos:
        videos = {name: Path(p) for name, p in body.videos.items()}
        missing = [f"{name}={p}" for name, p in videos.items() if not p.is_file()]
        if missing:
            raise HTTPException(
                status.HTTP_422_UNPROCESSABLE_CONTENT, f"video not found: {', '.join(missing)}"
            )
    try:
        pipeline.start(body.source, videos)
    except PipelineUnavailable as exc:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(exc)) from exc
    except CavewalkError as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from exc
    return StatusPublic.model_validate(pipeline.snapshot())


@router.post("/stop", response_model=StatusPublic)
def stop(pipeline: PipelineDep) -> StatusPublic:
    pipeline.stop()
    return StatusPublic.model_validate(pipeline.snapshot())
