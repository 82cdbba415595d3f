"""``api_router``: every resource's routes under ``/api/v1``.

To add a resource, add its module (exposing ``router``) to ``ROUTE_MODULES``.
Every router but health's requires the operator token when the server has one.
"""

from __future__ import annotations

import importlib

from fastapi import APIRouter

from app.api.deps import TokenDep

PUBLIC_ROUTE_MODULES: tuple[str, ...] = ("app.api.routes.health",)

ROUTE_MODULES: tuple[str, ...] = (
    "app.api.routes.status",
    "app.api.routes.pipeline",
    "app.api.routes.people",
    "app.api.routes.calibration",
    "app.api.routes.planner",
    "app.api.routes.participants",
    "app.api.routes.sessions",
    "app.api.routes.live",
    "app.api.routes.study",
    "app.api.routes.analysis",
)


def build_api_router() -> APIRouter:
    router = APIRouter(prefix="/api/v1")
    for name in PUBLIC_ROUTE_MODULES:
        router.include_router(importlib.import_module(name).router)
    for name in ROUTE_MODULES:
        router.include_router(importlib.import_module(name).router, dependencies=[TokenDep])
    return router


api_router = build_api_router()
