"""Backups of the database: the list, and one now (the dashboard's *Back up now*)."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, status
from fastapi.requests import HTTPConnection

from app.db.backup import BackupError
from app.schemas.backups import BackupPublic, BackupsPublic
from app.services.backup import BackupService

router = APIRouter(prefix="/backups", tags=["backups"])


def _service(conn: HTTPConnection) -> BackupService:
    service: BackupService = conn.app.state.backups
    return service


@router.get("", response_model=BackupsPublic)
def list_backups(conn: HTTPConnection) -> BackupsPublic:
    """The backup settings, the database's backups (newest first), the last one and its error."""
    return BackupsPublic.model_validate(_service(conn).status())


@router.post(
    "",
    response_model=BackupPublic,
    status_code=status.HTTP_201_CREATED,
    responses={503: {"description": "The backup could not be made (the reason is given); nothing changed"}},
)
def back_up_now(conn: HTTPConnection) -> BackupPublic:
    """A checked copy of the database now (reason ``manual``), events up to now included."""
    try:
        info = _service(conn).backup_now("manual")
    except BackupError as exc:
        raise HTTPException(status.HTTP_503_SERVICE_UNAVAILABLE, f"backup failed: {exc}") from exc
    return BackupPublic.model_validate(info.to_json())
