"""Lab-network security: operator token beyond loopback, CORS off by default, request size limit."""

from __future__ import annotations

from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from app.main import create_app, is_loopback, operator_token
from tests.app.conftest import make_settings


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
