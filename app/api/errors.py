"""Error responses of the app: domain exceptions to HTTP statuses, and JSON that always encodes.

``install_error_handlers(app)`` maps :class:`RecordNotFound` to 404, :class:`StateConflict` to
409, :class:`InputError` to 422 and any other :class:`CavewalkError` to 400, and answers
validation errors and ``HTTPException`` through :class:`SafeJSONResponse`: a response whose
content holds a non-finite float or a lone surrogate (an echoed input, a message quoting
one) is sent with those made encodable (``NaN`` -> ``"NaN"`` in echoes, ``null`` in data;
a surrogate as its ``\\uXXXX`` escape) instead of failing with HTTP 500.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

from app.db.repositories import RecordNotFound, StateConflict
from pipeline.errors import CavewalkError, InputError

_SURROGATE = re.compile("[\ud800-\udfff]")


def encodable(value: Any, non_finite: Callable[[float], Any] = lambda _x: None) -> Any:
    """``value`` (JSON-like) with non-finite floats replaced by ``non_finite(x)`` and lone
    surrogates in strings and keys written as their ``\\uXXXX`` escapes."""
    if isinstance(value, float):
        return value if math.isfinite(value) else non_finite(value)
    if isinstance(value, str):
        return _SURROGATE.sub(lambda m: f"\\u{ord(m.group()):04x}", value)
    if isinstance(value, dict):
        return {encodable(k, non_finite): encodable(v, non_finite) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [encodable(v, non_finite) for v in value]
    return value


class SafeJSONResponse(JSONResponse):
    """A JSONResponse that never fails to encode: NaN/Infinity become null, surrogates escapes."""

    def render(self, content: Any) -> bytes:
        try:
            return super().render(content)
        except (ValueError, UnicodeEncodeError):
            data = encodable(jsonable_encoder(content))
            return json.dumps(data, ensure_ascii=False, allow_nan=False, separators=(",", ":")).encode()


async def _validation_error(_request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, RequestValidationError)
    errors = jsonable_encoder(exc.errors(), custom_encoder={float: lambda x: x})
    return SafeJSONResponse({"detail": encodable(errors, non_finite=repr)}, status_code=422)


async def _http_exception(_request: Request, exc: Exception) -> JSONResponse:
    assert isinstance(exc, StarletteHTTPException)
    if exc.status_code in (204, 304):
        return JSONResponse(None, status_code=exc.status_code, headers=exc.headers)
    return SafeJSONResponse({"detail": exc.detail}, status_code=exc.status_code, headers=exc.headers)


def _domain(code: int) -> Callable[[Request, Exception], Any]:
    async def handle(_request: Request, exc: Exception) -> JSONResponse:
        message = exc.args[0] if exc.args else str(exc)
        return SafeJSONResponse({"detail": str(message)}, status_code=code)

    return handle


def install_error_handlers(app: FastAPI) -> None:
    app.add_exception_handler(RequestValidationError, _validation_error)
    app.add_exception_handler(StarletteHTTPException, _http_exception)
    app.add_exception_handler(RecordNotFound, _domain(404))
    app.add_exception_handler(StateConflict, _domain(409))
    app.add_exception_handler(InputError, _domain(422))
    app.add_exception_handler(CavewalkError, _domain(400))
