"""Start and stop the recognition pipeline and choose its source."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter, HTTPException, Request, status

from app.api.deps import PipelineDep
from app.db.errors import StateConflict
from app.schemas.live import PipelineStart, StatusPublic
from app.services.live import PipelineService, PipelineUnavailable
from pipeline.errors import CavewalkError, SourceError
from pipeline.sources.opencv import probe_video

router = APIRouter(prefix="/pipeline", tags=["pipeline"])


@router.get("", response_model=StatusPublic)
def pipeline_status(pipeline: PipelineDep) -> StatusPublic:
    return StatusPublic.model_validate(pipeline.snapshot())


def unusable_videos(videos: dict[str, Path]) -> list[str]:
    """``name=path`` of each video that is not a file that opens as a video.

    A missing file and one that exists but does not open get the same answer, so that the
    API does not tell a caller which paths exist on the server (issue 15)."""
    bad = []
    for name, path in videos.items():
        try:
            if not path.is_file():
                raise SourceError("not a file")
            probe_video(name, path)
        except (OSError, ValueError, CavewalkError):  # ValueError: a NUL in the path
            bad.append(f"{name}={path}")
    return bad


def _no_take_recording(request: Request, pipeline: PipelineService) -> None:
    """A start while a take records would put two runs (people numbered anew, maybe another
    calibration or model) in one take: refused until the take stops (stopping is never refused)."""
    recorder = getattr(request.app.state, "recorder", None)
    now = recorder.current() if recorder is not None else None
    if now is not None and pipeline.status().state not in ("stopped", "unavailable"):
        raise StateConflict(f"take {now['take_id']} is recording: stop it first (a new start of the running "
                            "pipeline would put two runs in one take)")


@router.post(
    "/start",
    response_model=StatusPublic,
    responses={409: {"description": "A take is recording"},
               503: {"description": "No pipeline can run in this server (the reason is given)"}},
)
def start(body: PipelineStart, pipeline: PipelineDep, request: Request) -> StatusPublic:
    _no_take_recording(request, pipeline)
    videos = None
    if body.videos:
        videos = {name: Path(p) for name, p in body.videos.items()}
        bad = unusable_videos(videos)
        if bad:
            raise HTTPException(
                status.HTTP_422_UNPROCESSABLE_CONTENT,
                f"cannot use as a video: {', '.join(bad)} (give video files the server can open)",
            )
    try:
        pipeline.start(body.source, videos)
    except PipelineUnavailable as exc:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(exc)) from exc
    except CavewalkError as exc:
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, str(exc)) from exc
    return StatusPublic.model_validate(pipeline.snapshot())


@router.post(
    "/restart",
    response_model=StatusPublic,
    responses={409: {"description": "The pipeline was never started, or a take is recording"},
               503: {"description": "No pipeline can run in this server (the reason is given)"}},
)
def restart(pipeline: PipelineDep, request: Request) -> StatusPublic:
    """Start again on the last start's source and videos: a calibration or action model made active
    since the last start is used from now on (the status's ``restart_for`` lists them)."""
    _no_take_recording(request, pipeline)
    try:
        pipeline.restart()
    except PipelineUnavailable as exc:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, str(exc)) from exc
    return StatusPublic.model_validate(pipeline.snapshot())


@router.post("/stop", response_model=StatusPublic)
def stop(pipeline: PipelineDep) -> StatusPublic:
    pipeline.stop()
    return StatusPublic.model_validate(pipeline.snapshot())
