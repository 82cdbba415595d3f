"""The OpenAPI schema and the ``/docs`` page: behind the operator token, with the real errors.

``install_docs(app)`` serves ``/openapi.json`` and ``/docs`` (Swagger UI) itself, so that both
ask for the operator token when the server has one (a bearer header, or ``?token=`` which
the ``/docs`` page hands on to the schema request). The schema lists for every route
the error responses it can really give, by what the route is:

- every route: 400 (a Host that does not name this server, or input the pipeline refuses);
- a route behind the token: 401, and the bearer security scheme;
- a state-changing route (POST, PUT, PATCH, DELETE): 403 (cross-site Origin refused) and
  409 (conflicts with the current state: a duplicate, a session not in the right state);
- a route with path parameters: 404;
- a route with a body: 413 (too large), 415 (not JSON), 422 (invalid, named field).

A route's own ``responses`` entries are kept (they describe its case better).
tests/app/test_http_input.py checks the statuses routes really give against this.
"""

from __future__ import annotations

from typing import Any
from urllib.parse import quote

from fastapi import FastAPI, Request, Response
from fastapi.openapi.docs import get_swagger_ui_html
from fastapi.openapi.utils import get_openapi

from app.api.deps import TokenDep
from app.api.errors import SafeJSONResponse
from app.api.fallback import api_routes, needs_token

STATE_CHANGING = {"POST", "PUT", "PATCH", "DELETE"}
_ERROR = {"content": {"application/json": {"schema": {"$ref": "#/components/schemas/ErrorMessage"}}}}


def _error(description: str) -> dict[str, Any]:
    return {"description": description, **_ERROR}


def route_errors(route: Any) -> dict[int, dict[str, Any]]:
    """The error responses ``route`` can give, by what it is (see the module docstring)."""
    out: dict[int, dict[str, Any]] = {
        400: _error("The Host header does not name this server, or the pipeline refuses the input")
    }
    if needs_token(route):
        out[401] = _error("The operator token is missing or wrong")
    if set(route.methods or ()) & STATE_CHANGING:
        out[403] = _error("A cross-site request: its Origin is neither this server nor a CORS origin")
        out[409] = _error("Conflicts with the current state (a duplicate, or not in the state it must be)")
    if route.dependant.path_params:
        out[404] = _error("No such record (or item) for the path's parameters")
    if route.body_field is not None:
        out[413] = _error("The request body is larger than server.max_request_bytes")
        out[415] = _error("The request body is not JSON (Content-Type: application/json)")
        out[422] = {"description": "Validation error: the detail names each bad field"}
    return out


def openapi_schema(app: FastAPI) -> dict[str, Any]:
    """The app's OpenAPI schema (cached), with every route's errors and the bearer scheme."""
    if app.openapi_schema is not None:
        return app.openapi_schema
    schema = get_openapi(
        title=app.title, version=app.version, summary=app.summary, description=app.description,
        routes=app.routes,
    )
    components = schema.setdefault("components", {})
    components.setdefault("schemas", {})["ErrorMessage"] = {
        "title": "ErrorMessage",
        "type": "object",
        "properties": {"detail": {"title": "Detail", "type": "string"}},
        "required": ["detail"],
    }
    components["securitySchemes"] = {"operatorToken": {"type": "http", "scheme": "bearer"}}
    paths = schema.get("paths", {})
    for route in api_routes(app):
        if not route.include_in_schema:
            continue
        for method in route.methods or ():
            operation = paths.get(route.path_format, {}).get(method.lower())
            if operation is None:
                continue
            responses = operation.setdefault("responses", {})
            for code, response in sorted(route_errors(route).items()):
                responses.setdefault(str(code), response)
            if needs_token(route):
                operation["security"] = [{"operatorToken": []}]
    app.openapi_schema = schema
    return schema


def install_docs(app: FastAPI) -> None:
    """``/openapi.json`` and ``/docs``, asking for the operator token when the server has one.

    Build the app with ``FastAPI(openapi_url=None, docs_url=None, redoc_url=None)``."""
    app.openapi = lambda: openapi_schema(app)  # type: ignore[method-assign]

    async def schema_json(_request: Request) -> Response:
        return SafeJSONResponse(app.openapi())

    async def docs(request: Request) -> Response:
        token = request.query_params.get("token")
        query = f"?token={quote(token, safe='')}" if token and request.app.state.token else ""
        return get_swagger_ui_html(openapi_url=f"/openapi.json{query}", title=f"{app.title} API")

    app.add_api_route("/openapi.json", schema_json, methods=["GET"], include_in_schema=False,
                      dependencies=[TokenDep])
    app.add_api_route("/docs", docs, methods=["GET"], include_in_schema=False, dependencies=[TokenDep])
