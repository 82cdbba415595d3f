"""The 3D view through the app's own port, behind the operator token (issue 15 D8).

The viser server listens on loopback only (``127.0.0.1:server.viser_port``, see
:meth:`app.viewer.Viewer.start`), whatever ``server.host`` is: nobody on the network can
reach it directly. The app proxies it at ``/viewer/``:

- ``GET /viewer/<path>``: viser's own HTTP answer (its client page) for ``<path>``;
- the WebSocket at ``/viewer`` (the viser client derives its socket URL from the page's
  address without the query and the trailing slash): every message both ways, binary and
  text, with the client's ``viser-v...`` subprotocol.

With an operator token, both need it: ``?token=`` or ``Authorization: Bearer`` on the page,
which then sets an HttpOnly, SameSite=Strict cookie scoped to ``/viewer`` so that the
client's own WebSocket (which cannot carry a header or the page's query) is let in too. The
cookie holds an HMAC of the token, not the token. Without the token the page answers 401 and
the WebSocket is closed with 1008 before anything is sent. The Host and Origin checks of
:mod:`app.api.origin` apply as on every other route.
"""

from __future__ import annotations

import asyncio
import contextlib
import hashlib
import hmac
import logging
import urllib.error
import urllib.request
from typing import TYPE_CHECKING

from fastapi import APIRouter, HTTPException, Request, WebSocket, status
from fastapi.requests import HTTPConnection
from fastapi.responses import RedirectResponse, Response
from starlette.concurrency import run_in_threadpool
from starlette.websockets import WebSocketDisconnect

from app.api.deps import bearer_token, token_matches

if TYPE_CHECKING:
    from app.viewer import Viewer

log = logging.getLogger(__name__)

VIEWER_PATH = "/viewer"
COOKIE = "cavewalk_viewer"
#: the most viser sends in one message (its own server's limit)
MAX_MESSAGE_BYTES = 50 * 1024 * 1024
UPSTREAM = "127.0.0.1"

router = APIRouter(include_in_schema=False)


def cookie_value(token: str) -> str:
    """What the viewer cookie holds: an HMAC of the token (the token itself never goes in a cookie)."""
    return hmac.new(token.encode(), b"cavewalk 3D view", hashlib.sha256).hexdigest()


def authorised(conn: HTTPConnection) -> tuple[bool, bool]:
    """(let in, by the token itself rather than the cookie)."""
    token: str | None = conn.app.state.token
    if token is None:
        return True, False
    if token_matches(token, bearer_token(conn)):
        return True, True
    cookie = conn.cookies.get(COOKIE)
    return cookie is not None and hmac.compare_digest(cookie.encode(), cookie_value(token).encode()), False


def _viewer(conn: HTTPConnection) -> Viewer | None:
    viewer: Viewer | None = getattr(conn.app.state, "viewer", None)
    return viewer


def _fetch(url: str) -> tuple[int, str, bytes]:
    try:
        with urllib.request.urlopen(url, timeout=30) as r:  # loopback http only
            return r.status, r.headers.get("Content-Type", "application/octet-stream"), r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.headers.get("Content-Type", "text/plain"), exc.read()


@router.get(VIEWER_PATH)
def viewer_root(request: Request) -> RedirectResponse:
    query = request.url.query
    target = f"{VIEWER_PATH}/" + (f"?{query}" if query else "")
    return RedirectResponse(target, status.HTTP_307_TEMPORARY_REDIRECT)


@router.get(VIEWER_PATH + "/{path:path}")
async def viewer_http(path: str, request: Request) -> Response:
    ok, by_token = authorised(request)
    if not ok:
        raise HTTPException(
            status.HTTP_401_UNAUTHORIZED,
            detail="operator token required: open /viewer/?token=<token>",
            headers={"WWW-Authenticate": "Bearer"},
        )
    viewer = _viewer(request)
    if viewer is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "the 3D view is off in the settings (server.viser)")
    code, content_type, body = await run_in_threadpool(_fetch, f"http://{UPSTREAM}:{viewer.port}/{path}")
    response = Response(body, status_code=code, media_type=content_type)
    response.headers["Cache-Control"] = "no-store"
    token: str | None = request.app.state.token
    if by_token and token is not None:
        response.set_cookie(COOKIE, cookie_value(token), httponly=True, samesite="strict", path=VIEWER_PATH)
    return response


@router.websocket(VIEWER_PATH)
@router.websocket(VIEWER_PATH + "/")
async def viewer_socket(ws: WebSocket) -> None:
    if not authorised(ws)[0]:
        await ws.close(code=status.WS_1008_POLICY_VIOLATION, reason="operator token required")
        return
    viewer = _viewer(ws)
    if viewer is None:
        await ws.close(code=status.WS_1008_POLICY_VIOLATION, reason="the 3D view is off")
        return
    import websockets

    offered = list(ws.scope.get("subprotocols") or [])
    protocol = next((p for p in offered if p.startswith("viser-v")), None)
    try:
        upstream = await websockets.connect(
            f"ws://{UPSTREAM}:{viewer.port}/",
            subprotocols=[protocol] if protocol else None,  # type: ignore[list-item]
            max_size=MAX_MESSAGE_BYTES,
            compression=None,
            open_timeout=30,
        )
    except (OSError, websockets.InvalidHandshake, TimeoutError) as exc:
        log.warning("the 3D view's server did not take the connection: %s", exc)
        await ws.close(code=status.WS_1011_INTERNAL_ERROR, reason="the 3D view is not available")
        return
    await ws.accept(subprotocol=protocol)

    async def down() -> None:  # viser -> browser
        async for message in upstream:
            if isinstance(message, bytes):
                await ws.send_bytes(message)
            else:
                await ws.send_text(message)

    async def up() -> None:  # browser -> viser
        while True:
            message = await ws.receive()
            if message["type"] == "websocket.disconnect":
                return
            if message.get("bytes") is not None:
                await upstream.send(message["bytes"])
            elif message.get("text") is not None:
                await upstream.send(message["text"])

    tasks = [asyncio.ensure_future(down()), asyncio.ensure_future(up())]
    try:
        done, _pending = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
        for task in done:
            error = task.exception()
            if error is not None and not isinstance(
                error, (WebSocketDisconnect, websockets.ConnectionClosed)
            ):
                log.debug("3D view proxy: %s", error)
    finally:
        for task in tasks:
            task.cancel()
        for task in tasks:
            with contextlib.suppress(BaseException):
                await task
        await upstream.close()
        with contextlib.suppress(Exception):
            await ws.close()
