"""WebSocket ``/ws/live``: the live status about ten times a second."""

from __future__ import annotations

import asyncio
import contextlib
import logging

from fastapi import APIRouter, WebSocket, WebSocketDisconnect, status

from app.api.deps import bearer_token, token_matches
from app.api.routes.status import live_snapshot

log = logging.getLogger(__name__)

router = APIRouter(tags=["live"])


@router.websocket("/ws/live")
async def live(ws: WebSocket) -> None:
    """Sends ``{"type": "status", ...}`` (the ``GET /status`` object) every ``1 / rate`` seconds.

    With an operator token configured, pass it as ``?token=...``; a wrong one closes with 1008.
    """
    if not token_matches(ws.app.state.token, bearer_token(ws)):
        await ws.close(code=status.WS_1008_POLICY_VIOLATION, reason="operator token required")
        return
    await ws.accept()
    period = 1.0 / ws.app.state.settings.server.live_rate_hz
    try:
        while True:
            snap = live_snapshot(ws)
            await ws.send_json({"type": "status", **snap})
            # Anything the client sends is ignored; a disconnect ends the loop promptly.
            with contextlib.suppress(TimeoutError):
                await asyncio.wait_for(ws.receive_text(), timeout=period)
    except WebSocketDisconnect:
        pass
    except RuntimeError as exc:  # sending after the client went away
        log.debug("live socket closed: %s", exc)
