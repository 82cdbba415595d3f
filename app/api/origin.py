"""Cross-site request forgery and DNS rebinding: the Host and Origin checks of every request.

A pure ASGI middleware, outermost in the app:

- **Host**: every HTTP request and WebSocket must name this server: a loopback name
  (``localhost``, ``127.0.0.1``, ``::1``), the address it is bound to (for a wildcard bind
  such as ``0.0.0.0``: this machine's host name and interface addresses), or a name in
  ``server.allowed_hosts`` (``"*"`` turns the check off, e.g. behind a reverse proxy that
  checks it). Anything else is 400. A page on ``evil.example`` whose DNS name was re-pointed
  at 127.0.0.1 (DNS rebinding) sends ``Host: evil.example`` and reads nothing.
- **Origin**: a state-changing request (POST, PUT, PATCH, DELETE) and a WebSocket handshake
  that carry an ``Origin`` must come from this server's own origin (scheme://Host) or a
  configured CORS origin, else 403 (a WebSocket is closed with 1008 before it is accepted).
  ``Origin: null`` (sandboxed frames, files) is refused. Without an Origin (curl, scripts,
  ``cavewalk record --url``) the request passes unless ``Sec-Fetch-Site`` says it comes
  from another site.

With the JSON-only body rule of :mod:`app.api.json_body`, a page on another site can
neither read the API nor change its state, token or no token.
"""

from __future__ import annotations

import json
import logging
import socket
from collections.abc import Iterable
from urllib.parse import urlsplit

from starlette.types import ASGIApp, Receive, Scope, Send

log = logging.getLogger(__name__)

LOOPBACK_NAMES = frozenset({"localhost", "127.0.0.1", "::1"})
WILDCARD_BINDS = frozenset({"", "0.0.0.0", "::"})
STATE_CHANGING = frozenset({"POST", "PUT", "PATCH", "DELETE"})


def normalise_host(name: str) -> str:
    """``"[::1]"`` -> ``"::1"``, ``"Cave.Lab."`` -> ``"cave.lab"``."""
    return name.strip().strip("[]").rstrip(".").lower()


def split_host_header(value: str) -> str:
    """The host part of a Host header: ``"[::1]:8000"`` -> ``"::1"``, ``"a.lab:80"`` -> ``"a.lab"``."""
    value = value.strip()
    if value.startswith("["):
        return normalise_host(value[1:].partition("]")[0])
    if value.count(":") == 1:
        value = value.partition(":")[0]
    return normalise_host(value)


def _machine_names() -> set[str]:
    """This machine's host names and interface addresses (for a wildcard bind)."""
    names = {socket.gethostname(), socket.getfqdn()}
    try:
        import psutil

        for addrs in psutil.net_if_addrs().values():
            for a in addrs:
                if a.family in (socket.AF_INET, socket.AF_INET6):
                    names.add(a.address.partition("%")[0])
    except Exception as exc:  # psutil may not see the interfaces in a sandbox
        log.debug("interface addresses unavailable: %s", exc)
    return {normalise_host(n) for n in names if n}


def _resolved(name: str) -> set[str]:
    try:
        infos = socket.getaddrinfo(name, None)
    except (OSError, UnicodeError):
        return set()
    return {normalise_host(str(info[4][0])) for info in infos}


def allowed_host_names(bind_host: str, extra: Iterable[str] = ()) -> frozenset[str] | None:
    """The Host names a server bound to ``bind_host`` answers to; None = any (``"*"`` in extra)."""
    extra = [normalise_host(e) for e in extra]
    if "*" in extra:
        return None
    names = set(LOOPBACK_NAMES) | set(extra)
    bind = normalise_host(bind_host)
    if bind in WILDCARD_BINDS:
        names |= _machine_names()
    else:
        names.add(bind)
        names |= _resolved(bind)
    return frozenset(names)


_DEFAULT_PORT = {"http": 80, "https": 443, "ws": 80, "wss": 443}


def _authority(scheme: str, netloc: str) -> tuple[str, int] | None:
    """(host, port) of ``scheme://netloc``, the port defaulted by the scheme; None if malformed."""
    try:
        parts = urlsplit(f"{scheme}://{netloc}")
        port = parts.port
    except ValueError:
        return None
    if scheme not in _DEFAULT_PORT or not parts.hostname or parts.path or parts.query:
        return None
    return normalise_host(parts.hostname), port if port is not None else _DEFAULT_PORT[scheme]


def origin_authority(origin: str) -> tuple[str, int] | None:
    """(host, port) of an Origin header value (``scheme://host[:port]``); None if it is not one."""
    scheme, sep, netloc = origin.strip().partition("://")
    return _authority(scheme.lower(), netloc) if sep else None


class SameOriginGuard:
    """400 for a Host this server does not answer to; 403 for a cross-site state change or WebSocket."""

    def __init__(
        self, app: ASGIApp, allowed_hosts: frozenset[str] | None, cors_origins: Iterable[str] = ()
    ) -> None:
        self.app = app
        self.allowed_hosts = allowed_hosts
        self.cors_origins = {a for a in (origin_authority(o) for o in cors_origins) if a is not None}

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] not in ("http", "websocket"):
            await self.app(scope, receive, send)
            return
        headers = {k.decode("latin-1").lower(): v.decode("latin-1") for k, v in scope.get("headers", [])}
        host_header = headers.get("host", "")
        foreign = (self.allowed_hosts is not None and host_header
                   and split_host_header(host_header) not in self.allowed_hosts)
        if foreign:
            await self._refuse(scope, send, 400, "the Host header does not name this server (a request "
                               "to another name, or DNS rebinding); add the name to "
                               "server.allowed_hosts if it is really this server")
            return
        check_origin = scope["type"] == "websocket" or scope.get("method", "GET") in STATE_CHANGING
        if check_origin:
            reason = self._cross_site(headers, host_header, scope)
            if reason is not None:
                await self._refuse(scope, send, 403, reason)
                return
        await self.app(scope, receive, send)

    def _cross_site(self, headers: dict[str, str], host_header: str, scope: Scope) -> str | None:
        origin = headers.get("origin")
        if origin is None:
            if headers.get("sec-fetch-site") in ("cross-site", "same-site"):
                return "cross-site request refused (Sec-Fetch-Site says another site sent it)"
            return None
        authority = origin_authority(origin)
        if authority is None:
            return f"cross-site request refused: Origin {origin!r} is not an http(s) origin"
        if authority in self.cors_origins:
            return None
        own = _authority(scope.get("scheme", "http"), host_header) if host_header else None
        if own is not None and own == authority:
            return None
        return (f"cross-site request refused: Origin {origin} is neither this server nor one of "
                "server.cors_origins")

    @staticmethod
    async def _refuse(scope: Scope, send: Send, status: int, message: str) -> None:
        log.warning("refused %s %s: %s", scope.get("method", "WEBSOCKET"), scope.get("path"), message)
        if scope["type"] == "websocket":
            await send({"type": "websocket.close", "code": 1008, "reason": message[:120]})
            return
        data = json.dumps({"detail": message}).encode()
        await send({
            "type": "http.response.start",
            "status": status,
            "headers": [(b"content-type", b"application/json"), (b"content-length", str(len(data)).encode())],
        })
        await send({"type": "http.response.body", "body": data})
