"""Hostile HTTP input (issue 15): non-finite numbers and lone surrogates in bodies, non-JSON
bodies, cross-site requests and DNS rebinding, OPTIONS and wrong methods, and the OpenAPI
schema against the statuses the routes really give.

The body cases are generated from the OpenAPI schema, so every body endpoint (and every
field of its body) is covered, including endpoints added later.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from app.main import create_app
from tests.app.conftest import make_settings

OWN = "http://testserver"  # the TestClient's origin (its Host is "testserver")
EVIL = "http://evil.example"
JSON = {"content-type": "application/json"}


@pytest.fixture()
def api(tmp_path: Path) -> Iterator[TestClient]:
    """The app (no pipeline) with one participant and one running session."""
    settings = make_settings(tmp_path, cors_origins=["http://dash.lab:9000"])
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        pid = c.post("/api/v1/participants", json={"code": "P01"}).json()["id"]
        sid = c.post("/api/v1/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
        assert c.post(f"/api/v1/sessions/{sid}/start").status_code == 200
        yield c


def operations(client: TestClient) -> list[tuple[str, str, dict[str, Any]]]:
    """(METHOD, path, operation) of every operation in the app's OpenAPI schema."""
    schema = client.app.openapi()  # type: ignore[attr-defined]
    return [(m.upper(), p, op) for p, ops in schema["paths"].items() for m, op in ops.items()]


def concrete(path: str) -> str:
    """A path with its parameters filled: ids 1 (they exist), names and formats plausible."""
    values = {"ext": "png", "name": "ssq", "camera": "cam01", "wall": "front"}
    out = path
    while "{" in out:
        start, end = out.index("{"), out.index("}")
        key = out[start + 1 : end]
        out = out[:start] + values.get(key, "1") + out[end + 1 :]
    return out


def body_fields(client: TestClient, op: dict[str, Any]) -> list[str]:
    schema = client.app.openapi()  # type: ignore[attr-defined]
    ref = op["requestBody"]["content"]["application/json"]["schema"]["$ref"]
    model = schema["components"]["schemas"][ref.rsplit("/", 1)[1]]
    return list(model["properties"])


def body_operations(client: TestClient) -> list[tuple[str, str, dict[str, Any]]]:
    ops = [o for o in operations(client) if "requestBody" in o[2]]
    assert len(ops) >= 7, f"the 7 body endpoints of today at least: {[o[:2] for o in ops]}"
    return ops


def names(response: Any) -> list[list[Any]]:
    detail = response.json()["detail"]
    assert isinstance(detail, list), detail
    return [d["loc"] for d in detail]


# ----------------------------------------------------------------------------------- D1 / D2
@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_non_finite_numbers_in_any_body_field_get_422_naming_it(api: TestClient, constant: str) -> None:
    before = api.get("/api/v1/participants").json()
    tried = 0
    for method, path, op in body_operations(api):
        for field in body_fields(api, op):
            r = api.request(method, concrete(path), content=f'{{"{field}": {constant}}}', headers=JSON)
            assert r.status_code == 422, f"{method} {path} {field}={constant}: {r.status_code} {r.text[:200]}"
            assert ["body", field] in names(r), f"{method} {path}: the detail names {field}: {r.text}"
            tried += 1
        nested = f'{{"a": [1, {{"b": {constant}}}]}}'  # deep inside, wherever the route would look
        r = api.request(method, concrete(path), content=nested, headers=JSON)
        assert r.status_code == 422 and ["body", "a", 1, "b"] in names(r), r.text
    assert tried >= 15
    assert api.get("/api/v1/participants").json() == before, "a rejected body stores nothing"


def test_lone_surrogates_in_any_string_or_key_get_422(api: TestClient) -> None:
    before = (api.get("/api/v1/participants").json(), api.get("/api/v1/sessions/1").json())
    for method, path, op in body_operations(api):
        for field in body_fields(api, op):
            for text in ('"\\ud800"', '"ok \\udfff"', '"\\udc00\\ud800"'):
                r = api.request(method, concrete(path), content=f'{{"{field}": {text}}}', headers=JSON)
                assert r.status_code == 422, f"{method} {path} {field}={text}: {r.status_code} {r.text[:200]}"
                assert ["body", field] in names(r), r.text
        r = api.request(method, concrete(path), content='{"\\ud800": 1}', headers=JSON)
        assert r.status_code == 422 and ["body", "\\ud800"] in names(r), f"{method} {path}: {r.text}"
    # the cases of the issue, nested keys included
    cases = [
        ("PATCH", "/api/v1/sessions/1", {"notes": "\ud800"}, ["body", "notes"]),
        ("POST", "/api/v1/participants", {"code": "P\ud800"}, ["body", "code"]),
        ("POST", "/api/v1/sessions/1/questionnaires",
         {"instrument": "ssq", "phase": "pre", "answers": {"\udbff": 1}}, ["body", "answers", "\\udbff"]),
        ("POST", "/api/v1/pipeline/start", {"source": "videos", "videos": {"\ud800": "/x.mp4"}},
         ["body", "videos", "\\ud800"]),
    ]  # fmt: skip
    for method, path, body, loc in cases:
        content = json.dumps(body)  # ensure_ascii writes the lone surrogate as \\udXXX
        r = api.request(method, path, content=content, headers=JSON)
        assert r.status_code == 422 and loc in names(r), f"{method} {path}: {r.status_code} {r.text}"
    assert (api.get("/api/v1/participants").json(), api.get("/api/v1/sessions/1").json()) == before
    # a real pair is text, and works
    r = api.post("/api/v1/participants", content='{"code": "P02", "notes": "\\ud83d\\ude00"}', headers=JSON)
    assert r.status_code == 201 and r.json()["notes"] == "\U0001f600"


def test_bodies_must_be_json(api: TestClient) -> None:
    for content_type in ("text/plain", "application/x-www-form-urlencoded", "multipart/form-data; b=x", None):
        headers = {"content-type": content_type} if content_type else {}
        r = api.post("/api/v1/participants", content='{"code": "P09"}', headers=headers)
        assert r.status_code == 415, f"{content_type}: {r.status_code} {r.text}"
        assert "application/json" in r.json()["detail"]
    assert api.post("/api/v1/participants", content='{"code":"P09"}',
                    headers={"content-type": "application/merge-patch+json"}).status_code == 201
    assert [p["code"] for p in api.get("/api/v1/participants").json()] == ["P01", "P09"]


# ------------------------------------------------------------------------------------------ D7
def test_cross_site_requests_cannot_change_state(api: TestClient) -> None:
    attacks = [
        {"headers": {"origin": EVIL, "content-type": "application/x-www-form-urlencoded"}, "content": "a=1"},
        {"headers": {"origin": EVIL, "content-type": "text/plain"}, "content": '{"x": 1}'},
        {"headers": {"origin": EVIL}},
        {"headers": {"origin": "null", "content-type": "text/plain"}, "content": "x"},
        {"headers": {"origin": "http://testserver.evil.example"}},
        {"headers": {"origin": "http://testserver:8001"}},  # another port is another origin
        {"headers": {"sec-fetch-site": "cross-site", "content-type": "text/plain"}, "content": "x"},
    ]
    targets = ["/api/v1/sessions/1/stop", "/api/v1/pipeline/stop", "/api/v1/calibration/runs"]
    for target in targets:
        for attack in attacks:
            r = api.post(target, **attack)  # type: ignore[arg-type]
            assert r.status_code == 403, f"{target} {attack}: {r.status_code} {r.text}"
            assert "cross-site" in r.json()["detail"]
    r = api.request("PATCH", "/api/v1/sessions/1", json={"notes": "pwned"}, headers={"origin": EVIL})
    assert r.status_code == 403
    session = api.get("/api/v1/sessions/1").json()
    assert session["status"] == "running" and session["notes"] == "", "the session was not touched"
    assert api.get("/api/v1/calibration/runs").json() == [], "no calibration run was started"
    # the app's own origin and a configured CORS origin may
    r = api.request("PATCH", "/api/v1/sessions/1", json={"notes": "ok"}, headers={"origin": OWN})
    assert r.status_code == 200, r.text
    r = api.request("PATCH", "/api/v1/sessions/1", json={"notes": "ok2"},
                    headers={"origin": "http://dash.lab:9000"})
    assert r.status_code == 200, r.text
    assert api.post("/api/v1/sessions/1/stop", headers={"origin": OWN}).json()["status"] == "stopped"


def test_a_foreign_host_reads_nothing(api: TestClient) -> None:
    for host in ("evil.example", "evil.example:8000", "127.0.0.1.evil.example", "[::2]"):
        r = api.get("/api/v1/participants", headers={"host": host})
        assert r.status_code == 400, f"Host {host}: {r.status_code} {r.text}"
        assert "P01" not in r.text and "Host" in r.json()["detail"]
    assert api.get("/", headers={"host": "evil.example"}).status_code == 400
    for host in ("testserver", "localhost:8000", "127.0.0.1", "[::1]:8000", "LOCALHOST"):
        assert api.get("/api/v1/participants", headers={"host": host}).status_code == 200, host


def test_the_websocket_refuses_foreign_origins_and_hosts(api: TestClient) -> None:
    for headers in ({"origin": EVIL}, {"origin": "null"}, {"host": "evil.example"}):
        with pytest.raises(WebSocketDisconnect) as info, api.websocket_connect("/api/v1/ws/live",
                                                                                headers=headers) as ws:
            ws.receive_json()
        assert info.value.code == 1008, headers
    with api.websocket_connect("/api/v1/ws/live", headers={"origin": OWN}) as ws:
        assert ws.receive_json()["type"] == "status"


# ------------------------------------------------------------------------- OPTIONS and methods
def test_options_and_wrong_methods_are_answered_by_the_api(api: TestClient) -> None:
    by_path: dict[str, set[str]] = {}
    for method, path, _op in operations(api):
        by_path.setdefault(path, set()).add(method)
    for path, methods in by_path.items():
        r = api.options(concrete(path))
        assert r.status_code == 204, f"OPTIONS {path}: {r.status_code} {r.headers.get('allow')}"
        allow = {m.strip() for m in r.headers["allow"].split(",")}
        assert methods | {"OPTIONS"} <= allow, f"{path}: Allow {allow}, routes {methods}"
        assert "HEAD" not in allow or "GET" in allow
        wrong = next(m for m in ("DELETE", "PUT", "PATCH", "POST") if m not in methods)
        r = api.request(wrong, concrete(path))
        assert r.status_code == 405, f"{wrong} {path}: {r.status_code}"
        assert set(r.headers["allow"].replace(" ", "").split(",")) == allow
    r = api.get("/api/v1/no-such-thing")
    assert r.status_code == 404 and r.headers["content-type"] == "application/json"


# ------------------------------------------------------------------------------- the schema
def documented(op: dict[str, Any]) -> set[int]:
    return {int(code) for code in op["responses"]}


def test_the_schema_lists_the_statuses_routes_really_give(tmp_path: Path) -> None:
    """Provoke each error class on every operation; the status it gives must be documented."""
    # a model upload has its own limit (server.max_model_bytes): both under the 30 kB body sent below
    settings = make_settings(tmp_path, token="tok-123", max_request_bytes=20_000, max_model_bytes=25_000)
    auth = {"authorization": "Bearer tok-123"}
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        ops = operations(c)
        assert c.post("/api/v1/participants", json={"code": "P01"}, headers=auth).status_code == 201
        seen: list[tuple[str, str, int]] = []

        def check(method: str, path: str, op: dict[str, Any], **kw: Any) -> int:
            r = c.request(method, concrete(path).replace("/1", "/999999"), **kw)
            assert r.status_code in documented(op), (
                f"{method} {path} gave {r.status_code} ({r.text[:120]}), documented {sorted(documented(op))}"
            )
            seen.append((method, path, r.status_code))
            return r.status_code

        for method, path, op in ops:
            public = path.endswith("/health")
            assert check(method, path, op) in ({200} if public else {401}), f"{method} {path} without token"
            assert check(method, path, op, headers={**auth, "host": "evil.example"}) == 400
            if method in ("POST", "PUT", "PATCH", "DELETE"):
                assert check(method, path, op, headers={**auth, "origin": EVIL}) == 403
            if "{" in path:
                check(method, path, op, headers=auth)  # a record that does not exist
            if "requestBody" in op:
                assert check(method, path, op, headers={**auth, "content-type": "text/plain"},
                             content="{}") == 415
                assert check(method, path, op, headers={**auth, **JSON}, content='{"x": NaN}') == 422
                assert check(method, path, op, headers={**auth, **JSON},
                             content=json.dumps({"notes": "x" * 30_000})) == 413
        conflicts = [
            ("POST", "/api/v1/participants", {"code": "P01"}),
        ]
        schema_ops = {(m, p): op for m, p, op in ops}
        for method, path, body in conflicts:
            r = c.request(method, path, json=body, headers=auth)
            assert r.status_code == 409 and 409 in documented(schema_ops[(method, path)])
        assert len(seen) > 100


def test_docs_and_schema_need_the_token(tmp_path: Path) -> None:
    with TestClient(create_app(make_settings(tmp_path, token="tok-123"), pipeline_factory=None)) as c:
        for path in ("/openapi.json", "/docs", "/redoc", "/docs/oauth2-redirect"):
            r = c.get(path)
            assert r.status_code in (401, 404), f"{path}: {r.status_code}"
        assert c.get("/openapi.json").status_code == 401 and c.get("/docs").status_code == 401
        schema = c.get("/openapi.json", headers={"authorization": "Bearer tok-123"}).json()
        assert schema["components"]["securitySchemes"]["operatorToken"]["scheme"] == "bearer"
        page = c.get("/docs?token=tok-123")
        assert page.status_code == 200 and "/openapi.json?token=tok-123" in page.text
        assert c.get("/openapi.json?token=tok-123").status_code == 200
    with TestClient(create_app(make_settings(tmp_path), pipeline_factory=None)) as c:  # loopback, no token
        assert c.get("/openapi.json").status_code == 200 and c.get("/docs").status_code == 200


# --------------------------------------------------------------------------- /pipeline/start
def test_pipeline_start_does_not_tell_which_files_exist(tmp_path: Path) -> None:
    real_file = tmp_path / "exists.mp4"
    real_file.write_text("not a video")
    missing = tmp_path / "missing.mp4"
    with TestClient(create_app(make_settings(tmp_path, token="tok-123"), pipeline_factory=None)) as c:
        body = {"source": "videos", "videos": {"cam01": str(missing)}}
        assert c.post("/api/v1/pipeline/start", json=body).status_code == 401, "behind the token"
        auth = {"authorization": "Bearer tok-123"}
        answers = []
        for path in (missing, real_file, tmp_path, Path("/etc/passwd"), Path("/nonexistent/x.mp4")):
            r = c.post("/api/v1/pipeline/start", json={"source": "videos", "videos": {"cam01": str(path)}},
                       headers=auth)
            assert r.status_code == 422, r.text
            answers.append(r.json()["detail"].replace(str(path), "PATH"))
        assert len(set(answers)) == 1, f"one message whether the file exists or not: {answers}"
