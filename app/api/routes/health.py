"""Liveness (no token needed: it tells nothing about the study)."""

from __future__ import annotations

from importlib.metadata import PackageNotFoundError, version

from fastapi import APIRouter
from sqlalchemy import text

from app.api.deps import SessionDep
from app.schemas.live import Health

router = APIRouter(tags=["health"])


def _version() -> str:
    try:
        return version("cavewalk")
    except PackageNotFoundError:
        return "0+unknown"


@router.get("/health", response_model=Health)
def health(db: SessionDep) -> Health:
    db.execute(text("SELECT 1"))
    return Health(version=_version(), database="ok")
