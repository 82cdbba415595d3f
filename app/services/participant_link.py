"""The participant page's link: the URL a tablet opens (with the session credential) and its QR code."""

from __future__ import annotations

import io
import socket

from fastapi import Request

from app.core.config import Settings


def _lan_address() -> str | None:
    """This machine's address on the lab network, from its host name (no packet is sent)."""
    try:
        addr = socket.gethostbyname(socket.gethostname())
    except OSError:
        return None
    return None if addr.startswith("127.") else addr


def base_url(settings: Settings, request: Request) -> str:
    """``server.public_url`` if set; else this server's address as a tablet on the network reaches it."""
    if settings.server.public_url:
        return settings.server.public_url.rstrip("/")
    host = settings.server.host
    port = request.url.port or settings.server.port
    if host in ("0.0.0.0", "::", ""):
        lan = _lan_address()
        if lan is not None:
            return f"{request.url.scheme}://{lan}:{port}"
    elif host not in ("127.0.0.1", "localhost", "::1"):
        return f"{request.url.scheme}://{host}:{port}"
    return str(request.base_url).rstrip("/")


def link_url(settings: Settings, request: Request, token: str) -> str:
    """The participant page with the credential in the fragment (never sent in a request line or log)."""
    return f"{base_url(settings, request)}/participant.html#t={token}"


def qr_svg(url: str) -> str:
    import segno

    buf = io.BytesIO()
    segno.make(url, error="m").save(buf, kind="svg", scale=5, border=2, xmldecl=False, svgns=True)
    return buf.getvalue().decode("utf-8")
