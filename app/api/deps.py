"""``Annotated`` dependency aliases of the routes (the FastAPI template's ``deps.py``)."""

from __future__ import annotations

import hmac
from collections.abc import Iterator
from typing import TYPE_CHECKING, Annotated

from fastapi import Depends, HTTPException, Path, status
from fastapi.requests import HTTPConnection
from sqlalchemy.orm import Session

from app.core.config import Settings

if TYPE_CHECKING:
    from app.services.calibration import CalibrationService
    from app.services.event_log import EventWriter
    from app.services.live import PipelineService
    from app.services.planner import PlannerService
    from app.viewer import Viewer


def get_db(conn: HTTPConnection) -> Iterator[Session]:
    """One SQLAlchemy session per request, closed afterwards."""
    with conn.app.state.session_factory() as db:
        yield db


def get_settings_dep(conn: HTTPConnection) -> Settings:
    settings: Settings = conn.app.state.settings
    return settings


def get_pipeline(conn: HTTPConnection) -> PipelineService:
    service: PipelineService = conn.app.state.pipeline
    return service


def get_events(conn: HTTPConnection) -> EventWriter:
    writer: EventWriter = conn.app.state.events
    return writer


def get_calibration(conn: HTTPConnection) -> CalibrationService:
    service: CalibrationService = conn.app.state.calibration
    return service


def get_planner(conn: HTTPConnection) -> PlannerService:
    service: PlannerService = conn.app.state.planner
    return service


def get_viewer(conn: HTTPConnection) -> Viewer | None:
    viewer: Viewer | None = conn.app.state.viewer
    return viewer


def token_matches(expected: str | None, given: str | None) -> bool:
    """True when no token is required, or ``given`` equals it (constant-time compare)."""
    if expected is None:
        return True
    return given is not None and hmac.compare_digest(expected.encode(), given.encode())


def bearer_token(conn: HTTPConnection) -> str | None:
    header = conn.headers.get("authorization", "")
    scheme, _, value = header.partition(" ")
    if scheme.lower() == "bearer" and value:
        return value.strip()
    return conn.query_params.get("token")


def require_token(conn: HTTPConnection) -> None:
    """The operator token, when the server requires one (a bearer header, or ``?token=`` for WebSockets)."""
    if conn.scope["type"] == "websocket":
        return  # checked by the WebSocket route itself, which must close with a code instead
    if not token_matches(conn.app.state.token, bearer_token(conn)):
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            detail="operator token required: send 'Authorization: Bearer <token>'",
            headers={"WWW-Authenticate": "Bearer"},
        )


SessionDep = Annotated[Session, Depends(get_db)]
SettingsDep = Annotated[Settings, Depends(get_settings_dep)]
PipelineDep = Annotated["PipelineService", Depends(get_pipeline)]
EventsDep = Annotated["EventWriter", Depends(get_events)]
CalibrationDep = Annotated["CalibrationService", Depends(get_calibration)]
ViewerDep = Annotated["Viewer | None", Depends(get_viewer)]
PlannerDep = Annotated["PlannerService", Depends(get_planner)]
TokenDep = Depends(require_token)
#: A row id in a URL path (SQLite INTEGER range).
IdPath = Annotated[int, Path(ge=1, le=2**63 - 1)]
