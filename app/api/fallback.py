"""What the API answers where no route of it matches: never the static-file mount's answers.

The dashboard is mounted at ``/``, so without this an ``OPTIONS /api/v1/participants`` or a
``DELETE /api/v1/status`` fell through to the file server (405 ``Allow: GET, HEAD``, the
file server's methods, not the route's). ``install_api_fallback(app)``, called after the API
routers and before the mount, adds one catch-all route under ``/api/`` that answers:

- ``OPTIONS``: 204 with ``Allow`` listing the methods of the routes at that path;
- another method a path's routes do not take: 405 with that ``Allow``;
- a path no route has: 404 (JSON).

It asks for the operator token like the routes it stands for (none for health's path).
"""

from __future__ import annotations

from typing import Any

import fastapi.routing
from fastapi import FastAPI, Request, Response
from fastapi.routing import APIRoute
from starlette.routing import Route

from app.api.deps import bearer_token, require_token, token_matches
from app.api.errors import SafeJSONResponse

API_PREFIX = "/api/"


def api_routes(app: FastAPI) -> list[Any]:
    """Every API route of ``app`` as the router runs it: path_format, methods, path_regex,
    dependant (with its router's dependencies) and body_field. FastAPI >= 0.16x keeps included
    routers whole (``iter_route_contexts`` flattens them); older ones flatten on include."""
    iterate = getattr(fastapi.routing, "iter_route_contexts", None)
    if iterate is None:
        return [r for r in app.routes if isinstance(r, APIRoute)]
    return [r for r in iterate(app.routes) if isinstance(r.original_route, APIRoute)]


def needs_token(route: Any) -> bool:
    """True when the route depends on :func:`require_token` (directly or through its router)."""
    stack = list(route.dependant.dependencies)
    while stack:
        dep = stack.pop()
        if dep.call is require_token:
            return True
        stack.extend(dep.dependencies)
    return False


def routes_at(app: FastAPI, path: str) -> list[Any]:
    """The API routes whose path pattern matches ``path``."""
    return [r for r in api_routes(app) if r.path_regex.match(path)]


def install_api_fallback(app: FastAPI, prefix: str = API_PREFIX) -> None:
    async def fallback(request: Request) -> Response:
        matching = routes_at(app, request.url.path)
        public = matching and not any(needs_token(r) for r in matching)
        if not public and not token_matches(request.app.state.token, bearer_token(request)):
            return SafeJSONResponse(
                    {"detail": "operator token required: send 'Authorization: Bearer <token>'"},
                    status_code=401,
                    headers={"WWW-Authenticate": "Bearer"},
                )
        if not matching:
            return SafeJSONResponse({"detail": f"no API route at {request.url.path}"}, status_code=404)
        methods = set().union(*(r.methods or set() for r in matching))
        allow = ", ".join(sorted(methods | {"OPTIONS"}))
        if request.method == "OPTIONS":
            return Response(status_code=204, headers={"Allow": allow})
        return SafeJSONResponse(
            {"detail": f"method {request.method} is not allowed here; allowed: {allow}"},
            status_code=405,
            headers={"Allow": allow},
        )

    methods = ["GET", "HEAD", "POST", "PUT", "PATCH", "DELETE", "OPTIONS", "TRACE"]
    app.router.routes.append(
        Route(f"{prefix.rstrip('/')}/{{rest:path}}", fallback, methods=methods, include_in_schema=False)
    )
