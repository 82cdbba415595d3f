"""Lab-network security: operator token beyond loopback, CORS off by default, request size limit."""

from __future__ import annotations

import asyncio
import hmac
import socket
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from app.main import create_app, is_loopback, operator_token
from tests.app.conftest import Served, make_settings


@pytest.mark.parametrize(
    ("host", "loopback"),
    [
        ("127.0.0.1", True),
        ("localhost", True),
        ("::1", True),
        ("[::1]", True),
        ("0.0.0.0", False),
        ("192.168.1.20", False),
        ("cave-server.lab", False),
    ],
)
def test_is_loopback(host: str, loopback: bool) -> None:
    assert is_loopback(host) is loopback


def test_token_only_required_beyond_loopback(tmp_path: Path) -> None:
    assert operator_token(make_settings(tmp_path)) is None
    generated = operator_token(make_settings(tmp_path, host="0.0.0.0"))
    assert generated is not None and len(generated) >= 24
    assert operator_token(make_settings(tmp_path, host="0.0.0.0")) != generated, "a fresh token per start"
    assert operator_token(make_settings(tmp_path, token="s3cret-token")) == "s3cret-token"


def test_api_and_websocket_need_the_bearer_token(tmp_path: Path) -> None:
    settings = make_settings(tmp_path, host="0.0.0.0", token="lab-token-123")
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        assert c.get("/api/v1/health").status_code == 200, "health tells nothing and stays open"
        r = c.post("/api/v1/participants", json={"code": "P01"})
        assert r.status_code == 401 and "token" in r.json()["detail"]
        assert c.get("/api/v1/participants", headers={"Authorization": "Bearer wrong"}).status_code == 401
        assert (
            c.get("/api/v1/participants", headers={"Authorization": "Bearer lab-token-123"}).json() == []
        ), "the rejected POST stored nothing"
        ok = c.post(
            "/api/v1/participants", json={"code": "P01"}, headers={"Authorization": "Bearer lab-token-123"}
        )
        assert ok.status_code == 201
        with pytest.raises(WebSocketDisconnect) as info, c.websocket_connect("/api/v1/ws/live") as ws:
            ws.receive_json()
        assert info.value.code == 1008
        with c.websocket_connect("/api/v1/ws/live?token=lab-token-123") as ws:
            assert ws.receive_json()["type"] == "status"


def test_cors_is_off_by_default_and_follows_the_settings(tmp_path: Path) -> None:
    origin = {"Origin": "http://evil.example"}
    with TestClient(create_app(make_settings(tmp_path), pipeline_factory=None)) as c:
        r = c.get("/api/v1/status", headers=origin)
        assert "access-control-allow-origin" not in r.headers
    settings = make_settings(tmp_path, cors_origins=["http://dash.lab"])
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        r = c.get("/api/v1/status", headers={"Origin": "http://dash.lab"})
        assert r.headers.get("access-control-allow-origin") == "http://dash.lab"
        r = c.get("/api/v1/status", headers=origin)
        assert "access-control-allow-origin" not in r.headers


def test_oversized_requests_get_413_and_store_nothing(tmp_path: Path) -> None:
    with TestClient(create_app(make_settings(tmp_path, max_request_bytes=2000), pipeline_factory=None)) as c:
        big = {"code": "P01", "notes": "x" * 5000}
        r = c.post("/api/v1/participants", json=big)
        assert r.status_code == 413 and "2000 bytes" in r.json()["detail"]

        def chunks():  # no Content-Length: a streamed body
            yield b'{"code": "P02", "notes": "'
            for _ in range(10):
                yield b"y" * 500
            yield b'"}'

        r = c.post("/api/v1/participants", content=chunks(), headers={"Content-Type": "application/json"})
        assert r.status_code == 413
        assert c.get("/api/v1/participants").json() == []
        assert c.post("/api/v1/participants", json={"code": "P03", "notes": "short"}).status_code == 201


def test_a_model_upload_has_its_own_larger_limit(tmp_path: Path) -> None:
    """POST /api/v1/models carries an action model (base64 in JSON, ~1.1 MB for the committed one):
    it may be up to server.max_model_bytes; every other request stays under max_request_bytes."""
    settings = make_settings(tmp_path, max_request_bytes=2000, max_model_bytes=8000)
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        upload = {"name": "m", "onnx_base64": "QUFB" * 1000}  # 4 kB: over 2000, under 8000
        r = c.post("/api/v1/models", json=upload)
        assert r.status_code != 413 and 400 <= r.status_code < 500, r.text  # refused for what it is
        assert "request body larger" not in r.text
        r = c.post("/api/v1/models", json={"name": "m", "onnx_base64": "QUFB" * 3000})
        assert r.status_code == 413 and "8000 bytes" in r.json()["detail"]
        r = c.post("/api/v1/participants", json={"code": "P01", "notes": "x" * 4000})
        assert r.status_code == 413 and "2000 bytes" in r.json()["detail"], "other routes keep their limit"


# ------------------------------------------------------------------ what held (issue 15): kept held
TRAVERSALS = [
    "/../pyproject.toml", "/../../etc/passwd", "/..%2fpyproject.toml", "/%2e%2e/pyproject.toml",
    "/%2e%2e%2fpyproject.toml", "/css/../../pyproject.toml", "/css/..%2f..%2fpyproject.toml",
    "/js/%2e%2e/%2e%2e/pyproject.toml", "/..\\pyproject.toml", "/..%5cpyproject.toml",
    "/css/..%5c..%5cpyproject.toml", "/%252e%252e/pyproject.toml", "/%252e%252e%252fpyproject.toml",
    "/....//pyproject.toml", "/..;/pyproject.toml", "/.%2e/pyproject.toml", "/%2e./pyproject.toml",
    "/%c0%ae%c0%ae/pyproject.toml", "/%c0%af../pyproject.toml", "//etc/passwd", "/%2fetc%2fpasswd",
    "/css/%00../../pyproject.toml", "/api/v1/../../pyproject.toml", "/api/v1/%2e%2e/%2e%2e/pyproject.toml",
    "/js/../../../../../../etc/passwd", "/index.html/../../pyproject.toml",
]  # fmt: skip


def raw_get(port: int, target: str) -> tuple[str, bytes]:
    """GET ``target`` byte for byte (an HTTP client library would normalise the dots away)."""
    with socket.create_connection(("127.0.0.1", port), timeout=30) as s:
        s.sendall(f"GET {target} HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n".encode())
        data = b""
        while chunk := s.recv(65536):
            data += chunk
    return data.split(b"\r\n", 1)[0].decode(), data


def test_path_traversal_variants_get_404(tmp_path: Path) -> None:
    assert len(TRAVERSALS) == 26
    with Served(make_settings(tmp_path), pipeline_factory=None, autostart=None) as s:
        port = s.settings.server.port
        status, body = raw_get(port, "/index.html")
        assert status.endswith("200 OK") and b"<html" in body.lower(), "the files themselves are served"
        for target in TRAVERSALS:
            status, body = raw_get(port, target)
            assert " 404 " in status, f"{target}: {status}"
            assert b"[build-system]" not in body and b"root:" not in body, target


def test_an_11_mb_body_gets_413_with_or_without_a_length(client: TestClient) -> None:
    big = b'{"code": "P01", "notes": "' + b"x" * 11_000_000 + b'"}'
    r = client.post("/api/v1/participants", content=big, headers={"content-type": "application/json"})
    assert r.status_code == 413

    def chunks() -> Iterator[bytes]:
        for i in range(0, len(big), 1 << 20):
            yield big[i : i + (1 << 20)]

    r = client.post("/api/v1/participants", content=chunks(), headers={"content-type": "application/json"})
    assert r.status_code == 413
    assert client.get("/api/v1/participants").json() == [], "nothing stored"


def race(n: int, call: Callable[[int], int]) -> list[int]:
    """``call(i)`` from n threads released at the same instant; their statuses."""
    barrier = threading.Barrier(n)
    out: list[int] = [0] * n

    def run(i: int) -> None:
        barrier.wait()
        out[i] = call(i)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(n)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=60)
    return out


def test_races_on_duplicate_codes_and_session_starts_have_exactly_one_winner(tmp_path: Path) -> None:
    with Served(make_settings(tmp_path), pipeline_factory=None, autostart=None) as s:
        api = f"{s.base}/api/v1"
        with httpx.Client(timeout=60) as h:
            codes = race(12, lambda _i: h.post(f"{api}/participants", json={"code": "P07"}).status_code)
            assert sorted(codes) == [201] + [409] * 11, codes
            pid = h.get(f"{api}/participants").json()[0]["id"]
            others = [h.post(f"{api}/participants", json={"code": c}).json()["id"] for c in ("P08", "P09")]
            sid = h.post(f"{api}/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
            same = race(8, lambda _i: h.post(f"{api}/sessions/{sid}/start").status_code)
            assert sorted(same) == [200] + [409] * 7, same
            assert h.post(f"{api}/sessions/{sid}/stop").status_code == 200
            sids = [
                h.post(f"{api}/sessions", json={"participant_id": p, "condition": "CC"}).json()["id"]
                for p in others
            ]
            both = race(8, lambda i: h.post(f"{api}/sessions/{sids[i % 2]}/start").status_code)
            assert sorted(both) == [200] + [409] * 7, f"one session runs at a time: {both}"
            running = [x for x in h.get(f"{api}/sessions").json() if x["status"] == "running"]
            assert len(running) == 1


def test_the_token_is_compared_in_constant_time(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    import app.api.deps as deps

    calls: list[tuple[bytes, bytes]] = []
    real = hmac.compare_digest

    def spy(a: bytes, b: bytes) -> bool:
        calls.append((a, b))
        return real(a, b)

    monkeypatch.setattr(deps.hmac, "compare_digest", spy)
    settings = make_settings(tmp_path, host="0.0.0.0", token="lab-token-123")
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        assert c.get("/api/v1/status", headers={"Authorization": "Bearer lab-token-12X"}).status_code == 401
        assert calls == [(b"lab-token-123", b"lab-token-12X")], "the HTTP check goes through compare_digest"
        with pytest.raises(WebSocketDisconnect), c.websocket_connect("/api/v1/ws/live?token=nope") as ws:
            ws.receive_json()
        assert calls[-1] == (b"lab-token-123", b"nope"), "the WebSocket check too"
        assert c.get("/openapi.json?token=zzz").status_code == 401 and calls[-1][1] == b"zzz"


def test_every_route_but_health_answers_401_without_the_token(tmp_path: Path) -> None:
    settings = make_settings(tmp_path, host="0.0.0.0", token="lab-token-123")
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        schema = c.get("/openapi.json", headers={"Authorization": "Bearer lab-token-123"}).json()
        checked = 0
        for path, ops in schema["paths"].items():
            target = path
            for key in ("{ext}", "{name}", "{camera}", "{wall}"):
                target = target.replace(key, {"{ext}": "png", "{name}": "ssq"}.get(key, "front"))
            target = target.replace("{participant_id}", "1").replace("{session_id}", "1")
            target = target.replace("{run_id}", "1")
            for method in ops:
                r = c.request(
                    method.upper(),
                    target,
                    headers={"content-type": "application/json"},
                    content="{}" if method in ("post", "put", "patch") else None,
                )
                expected = 200 if path == "/api/v1/health" else 401
                assert r.status_code == expected, f"{method.upper()} {path}: {r.status_code}"
                checked += 1
        assert checked >= 40
        for path in ("/openapi.json", "/docs", "/api/v1/no-such-route"):
            assert c.get(path).status_code == 401, path
        assert c.options("/api/v1/participants").status_code == 401
        with pytest.raises(WebSocketDisconnect) as info, c.websocket_connect("/api/v1/ws/live") as ws:
            ws.receive_json()
        assert info.value.code == 1008


# --- the 3D view (issue 15 D8): viser on loopback only, proxied at /viewer/ behind the token ---

VIEW_TOKEN = "lab-token-3d"
SEEN_PERSON = {
    "navigator": 7,
    "action": {"label": "forward", "yaw_deg": 10.0},
    "extra": {"people3d": [{"user_id": 7, "joints": [[0.1 * i, 0.0, 0.1 * i] for i in range(17)]}]},
}


def viser_messages(raw: bytes) -> list[dict[str, Any]]:
    """The messages of one viser WebSocket frame (zstd-compressed msgpack after a 16-byte header)."""
    import msgspec
    import zstandard

    size, compressed = int.from_bytes(raw[:8], "little"), int.from_bytes(raw[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(raw[16 : 16 + compressed], max_output_size=size)
    return list(msgspec.msgpack.decode(inner)["messages"])


async def scene_names(url: str, headers: dict[str, str], until: str, timeout_s: float = 60.0) -> set[str]:
    """Connect like the viser client does and collect scene-node names until ``until`` arrives.

    The deadline only bounds a hung server: the scene is replayed at once on connect."""
    import viser
    import websockets

    names: set[str] = set()
    async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
                                  additional_headers=headers, max_size=None) as ws:  # fmt: skip
        deadline = asyncio.get_running_loop().time() + timeout_s
        while until not in names:
            left = deadline - asyncio.get_running_loop().time()
            assert left > 0, f"{until} never arrived; names seen: {sorted(names)[:30]}"
            raw = await asyncio.wait_for(ws.recv(), left)
            assert isinstance(raw, bytes)
            names |= {str(m["name"]) for m in viser_messages(raw) if isinstance(m.get("name"), str)}
    return names


async def refused(url: str, headers: dict[str, str] | None = None) -> int:
    """The HTTP status a WebSocket handshake is refused with (it must be refused: nothing is received)."""
    import viser
    import websockets

    try:
        async with websockets.connect(url, subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
                                      additional_headers=headers or {}) as ws:  # fmt: skip
            raw = await asyncio.wait_for(ws.recv(), 30)
    except websockets.InvalidStatus as exc:
        return int(exc.response.status_code)
    raise AssertionError(f"the handshake was accepted and sent {len(raw)} bytes")


def test_the_3d_view_beyond_loopback_needs_the_token(tmp_path: Path) -> None:
    import psutil

    from app.api.viewer_proxy import COOKIE

    settings = make_settings(tmp_path, viser=True, host="0.0.0.0", token=VIEW_TOKEN)
    with Served(settings, pipeline_factory=None, autostart=None) as s:
        viewer = s.app.state.viewer
        assert viewer is not None
        viewer.update(SEEN_PERSON)
        listening = {c.laddr.ip for c in psutil.net_connections("inet")
                     if c.status == psutil.CONN_LISTEN and c.laddr.port == viewer.port}  # fmt: skip
        assert listening == {"127.0.0.1"}, f"viser must listen on loopback only, not {listening}"
        page = f"{s.base}/viewer/"
        ws_url = f"ws://127.0.0.1:{settings.server.port}/viewer"
        assert httpx.get(page, timeout=60).status_code == 401
        assert httpx.get(f"{page}?token=wrong", timeout=60).status_code == 401
        assert httpx.get(f"{s.base}/api/v1/info", timeout=60).status_code == 401
        info = httpx.get(f"{s.base}/api/v1/info", headers={"Authorization": f"Bearer {VIEW_TOKEN}"}).json()
        assert info["viewer_url"] == "/viewer/"
        r = httpx.get(f"{page}?token={VIEW_TOKEN}", timeout=60)
        assert r.status_code == 200 and "<title>Viser</title>" in r.text, "viser's own page, through the app"
        cookie = r.cookies[COOKIE]
        assert VIEW_TOKEN not in cookie and "httponly" in r.headers["set-cookie"].lower()
        assert "samesite=strict" in r.headers["set-cookie"].lower()

        assert asyncio.run(refused(ws_url)) == 403, "no token: refused before anything is sent"
        assert asyncio.run(refused(f"{ws_url}?token=wrong")) == 403
        assert asyncio.run(refused(ws_url, {"Cookie": f"{COOKIE}=forged"})) == 403
        assert asyncio.run(refused(ws_url, {"Cookie": f"{COOKIE}={cookie}",
                                            "Origin": "http://evil.example"})) == 403  # fmt: skip
        for headers, url in (({"Cookie": f"{COOKIE}={cookie}"}, ws_url),
                             ({}, f"{ws_url}?token={VIEW_TOKEN}"),
                             ({"Authorization": f"Bearer {VIEW_TOKEN}"}, f"{ws_url}/")):  # fmt: skip
            names = asyncio.run(scene_names(url, headers, until="/people/7/joints"))
            assert {"/navigator/arrow", "/cameras/cam01"} <= names, sorted(names)


def test_the_3d_view_on_loopback_is_open_through_the_proxy(tmp_path: Path) -> None:
    settings = make_settings(tmp_path, viser=True)
    with Served(settings, pipeline_factory=None, autostart=None) as s:
        s.app.state.viewer.update(SEEN_PERSON)
        r = httpx.get(f"{s.base}/viewer", timeout=60, follow_redirects=True)
        assert r.status_code == 200 and "<title>Viser</title>" in r.text
        url = f"ws://127.0.0.1:{settings.server.port}/viewer"
        names = asyncio.run(scene_names(url, {}, "/people/7/joints"))
        assert "/navigator/arrow" in names
