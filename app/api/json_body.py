"""Request bodies of the API: JSON only, and JSON that every part of the app can encode again.

A pure ASGI middleware in front of the routes:

- a request under ``/api/`` that carries a body must say ``Content-Type: application/json``
  (or ``application/*+json``), else 415. A cross-site form or ``text/plain`` body (what a
  page on another site can send without a CORS preflight) never reaches a route.
- ``NaN``, ``Infinity`` and ``-Infinity`` (Python's json accepts them, JSON does not) and
  lone UTF-16 surrogates (``"\\ud800"``, which no UTF-8 text can hold) anywhere in the body,
  in a value or in a key, give 422 naming where: ``{"detail": [{"loc": ["body", "notes"],
  "msg": ..., "type": ...}]}``, the shape of FastAPI's own validation errors. Left in, they
  made pydantic's error echo or our own messages unencodable (HTTP 500), or reached the
  database.

The body is read once (the size limit is enforced outside, by :class:`app.api.limits.BodySizeLimit`)
and replayed to the app unchanged.
"""

from __future__ import annotations

import json
import re
from typing import Any

from starlette.types import ASGIApp, Message, Receive, Scope, Send

API_PREFIX = "/api/"
_SURROGATE = re.compile("[\ud800-\udfff]")


class _NonFinite:
    __slots__ = ("name",)

    def __init__(self, name: str) -> None:
        self.name = name


def _escaped(text: str) -> str:
    """``text`` with any lone surrogate written as its JSON escape (``\\ud800``)."""
    return _SURROGATE.sub(lambda m: f"\\u{ord(m.group()):04x}", text)


def body_problems(value: Any, loc: tuple[str | int, ...] = ("body",)) -> list[dict[str, Any]]:
    """The validation errors (FastAPI's shape) of a parsed body's non-finite numbers and lone
    surrogates, each with its location; [] when there are none.

    >>> body_problems(json.loads('{"a": [1, NaN]}', parse_constant=_NonFinite))[0]["loc"]
    ['body', 'a', 1]
    """
    out: list[dict[str, Any]] = []
    if isinstance(value, _NonFinite):
        out.append({
            "type": "finite_number",
            "loc": list(loc),
            "msg": f"{value.name} is not a JSON number: send a finite number (or null where allowed)",
        })
    elif isinstance(value, str):
        if _SURROGATE.search(value):
            out.append({
                "type": "string_unicode",
                "loc": list(loc),
                "msg": "the text holds a lone UTF-16 surrogate escape (\\ud800-\\udfff), which is not text",
            })
    elif isinstance(value, dict):
        for key, item in value.items():
            where = (*loc, _escaped(key))
            if _SURROGATE.search(key):
                out.append({
                    "type": "string_unicode",
                    "loc": list(where),
                    "msg": "the key holds a lone UTF-16 surrogate escape (\\ud800-\\udfff): not text",
                })
            out.extend(body_problems(item, where))
    elif isinstance(value, list):
        for i, item in enumerate(value):
            out.extend(body_problems(item, (*loc, i)))
    return out


def is_json_media_type(content_type: str) -> bool:
    media = content_type.split(";", 1)[0].strip().lower()
    main, _, sub = media.partition("/")
    return main == "application" and (sub == "json" or sub.endswith("+json"))


class JsonBodyGuard:
    """415 for a non-JSON body under ``/api/``, 422 for NaN/Infinity or lone surrogates in it."""

    def __init__(self, app: ASGIApp, prefix: str = API_PREFIX) -> None:
        self.app = app
        self.prefix = prefix

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http" or not scope["path"].startswith(self.prefix):
            await self.app(scope, receive, send)
            return
        messages: list[Message] = []
        chunks: list[bytes] = []
        while True:
            message = await receive()
            messages.append(message)
            if message["type"] != "http.request":
                break
            chunks.append(message.get("body", b""))
            if not message.get("more_body", False):
                break
        body = b"".join(chunks)
        if body:
            content_type = ""
            for name, value in scope.get("headers", []):
                if name == b"content-type":
                    content_type = value.decode("latin-1")
            if not is_json_media_type(content_type):
                shown = content_type.split(";", 1)[0].strip() or "none"
                await _reply(send, 415, {"detail": f"the request body must be JSON (Content-Type: "
                                                   f"application/json), got Content-Type: {shown}"})
                return
            problems = _problems(body)
            if problems:
                await _reply(send, 422, {"detail": problems})
                return
        pending = list(messages)

        async def replay() -> Message:
            if pending:
                return pending.pop(0)
            return await receive()

        await self.app(scope, replay, send)


def _problems(body: bytes) -> list[dict[str, Any]]:
    try:
        parsed = json.loads(body, parse_constant=_NonFinite)
    except UnicodeDecodeError:
        return [{"type": "json_invalid", "loc": ["body"], "msg": "the body is not UTF-8 text"}]
    except json.JSONDecodeError:
        return []  # FastAPI answers malformed JSON with its own 422
    except RecursionError:
        return [_TOO_DEEP]
    try:
        return body_problems(parsed)
    except RecursionError:
        return [_TOO_DEEP]


_TOO_DEEP = {"type": "json_invalid", "loc": ["body"], "msg": "the JSON is nested too deeply"}


async def _reply(send: Send, status: int, content: dict[str, Any]) -> None:
    data = json.dumps(content, ensure_ascii=True).encode()
    await send({
        "type": "http.response.start",
        "status": status,
        "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(data)).encode())],
    })
    await send({"type": "http.response.body", "body": data})
