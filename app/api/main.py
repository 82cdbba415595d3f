"""``api_router``: every resource's routes under ``/api/v1`` (the FastAPI template's ``api/main.py``).

To add a resource, write ``app/api/routes/<resource>.py`` exposing ``router``, import it
here and include it below. Every router but health's requires the operator token when
the server has one.
"""

from __future__ import annotations

from fastapi import APIRouter

from app.api.deps import TokenDep
from app.api.routes import (
    analysis,
    backups,
    calibration,
    health,
    live,
    models,
    participant,
    participants,
    people,
    pipeline,
    planner,
    sessions,
    status,
    study,
    takes,
)

api_router = APIRouter(prefix="/api/v1")
api_router.include_router(health.router)
# the participant page's API: authenticated by its session-scoped link, not by the operator token
api_router.include_router(participant.router)
api_router.include_router(status.router, dependencies=[TokenDep])
api_router.include_router(pipeline.router, dependencies=[TokenDep])
api_router.include_router(people.router, dependencies=[TokenDep])
api_router.include_router(calibration.router, dependencies=[TokenDep])
api_router.include_router(planner.router, dependencies=[TokenDep])
api_router.include_router(participants.router, dependencies=[TokenDep])
api_router.include_router(sessions.router, dependencies=[TokenDep])
api_router.include_router(live.router, dependencies=[TokenDep])
api_router.include_router(study.router, dependencies=[TokenDep])
api_router.include_router(analysis.router, dependencies=[TokenDep])
api_router.include_router(takes.router, dependencies=[TokenDep])
api_router.include_router(models.router, dependencies=[TokenDep])
api_router.include_router(backups.router, dependencies=[TokenDep])
