"""The live status of the pipeline (the same object the WebSocket sends) and what the dashboard needs."""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter
from fastapi.requests import HTTPConnection
from pydantic import BaseModel

from app.api.deps import PipelineDep, SettingsDep, ViewerDep
from app.schemas.live import StatusPublic

router = APIRouter(tags=["status"])


class DashboardInfo(BaseModel):
    viser_port: int | None  # the viser server's own port, on loopback only
    viewer_url: str | None  # the 3D view for the dashboard: the app's proxy, behind the token
    cameras: list[str]
    walls: list[str]
    live_rate_hz: float
    pipeline_available: bool
    pipeline_unavailable_reason: str


def live_snapshot(conn: HTTPConnection) -> dict[str, Any]:
    """The pipeline's newest status plus the app's own live facts (running study session, active
    calibration, the no-locomotion alarm): the object the WebSocket sends (``LiveFeed.compose``)."""
    message: dict[str, Any] = conn.app.state.feed.compose()
    return message


@router.get("/status", response_model=StatusPublic)
def get_status(conn: HTTPConnection) -> StatusPublic:
    return StatusPublic.model_validate(live_snapshot(conn))


@router.get("/info", response_model=DashboardInfo)
def info(settings: SettingsDep, viewer: ViewerDep, pipeline: PipelineDep) -> DashboardInfo:
    return DashboardInfo(
        viser_port=viewer.port if viewer is not None else None,
        viewer_url="/viewer/" if viewer is not None else None,
        cameras=[c.name for c in settings.cameras],
        walls=[w.name for w in settings.cave.geometry().walls],
        live_rate_hz=settings.server.live_rate_hz,
        pipeline_available=pipeline.available,
        pipeline_unavailable_reason=pipeline.unavailable_reason,
    )
