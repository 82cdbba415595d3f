"""WebSocket ``/ws/live``: the live status as the pipeline pushes it (about ten times a second)."""

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
    """Sends ``{"type": "status", ...}`` (the ``GET /status`` object): the current one at once, then
    each new one the app's live feed hands on (``app.services.live.LiveFeed``: at most
    ``server.live_rate_hz`` a second, the newest when the client is slower).

    With an operator token configured, pass it as ``?token=...``; a wrong one closes with 1008.
    """
    if not token_matches(ws.app.state.token, bearer_token(ws)):
        await ws.close(code=status.WS_1008_POLICY_VIOLATION, reason="operator token required")
        return
    await ws.accept()
    feed = ws.app.state.feed
    messages = feed.subscribe()
    closed = asyncio.ensure_future(_until_closed(ws))
    try:
        await ws.send_json({"type": "status", **live_snapshot(ws)})
        while True:
            message = asyncio.ensure_future(messages.get())
            await asyncio.wait({message, closed}, return_when=asyncio.FIRST_COMPLETED)
            if not message.done():
                message.cancel()
                break
            await ws.send_json({"type": "status", **message.result()})
    except WebSocketDisconnect:
        pass
    except RuntimeError as exc:  # sending after the client went away
        log.debug("live socket closed: %s", exc)
    finally:
        feed.unsubscribe(messages)
        closed.cancel()
        with contextlib.suppress(asyncio.CancelledError, WebSocketDisconnect, RuntimeError):
            await closed


async def _until_closed(ws: WebSocket) -> None:
    """Until the client goes away (anything it sends is ignored)."""
    while (await ws.receive())["type"] != "websocket.disconnect":
        pass
