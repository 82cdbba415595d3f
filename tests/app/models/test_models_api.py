"""The registry of action models through the API: the base entry, uploads refused or registered,
activation, roll back, and the active model's id in a study session's log (issue 18 item 5)."""

from __future__ import annotations

import base64
import hashlib
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH
from tests.app.models.onnx_files import three_class_model, with_metadata


def _upload(client: TestClient, path: Path, **extra: Any) -> Any:
    body = {"name": path.name, "onnx_base64": base64.b64encode(path.read_bytes()).decode(), **extra}
    return client.post("/api/v1/models", json=body)


def _state(client: TestClient, folder: Path) -> tuple[Any, list[str]]:
    models = client.get("/api/v1/models").json()
    files = sorted(p.name for p in folder.iterdir()) if folder.is_dir() else []
    return models, files


def test_the_committed_model_is_the_active_base_entry_with_its_card(client: TestClient) -> None:
    models = client.get("/api/v1/models").json()
    assert len(models) == 1, models
    base = models[0]
    assert base["kind"] == "base" and base["active"], base
    assert base["sha256"] == hashlib.sha256(DEFAULT_MODEL_PATH.read_bytes()).hexdigest()
    assert base["card"]["classes"] == ["still", "forward", "left", "right"]
    assert base["card"]["window"] == 32 and base["card"]["features"] in ("v1", "v2")
    md = client.get(f"/api/v1/models/{base['id']}/card.md")
    assert md.status_code == 200 and "Model card" in md.text
    assert client.get("/api/v1/models/active").json()["id"] == base["id"]


def _bad_files(tmp: Path) -> dict[str, tuple[Path, dict[str, Any], str]]:
    text = tmp / "notes.onnx"
    text.write_text("this is not a model\n")
    return {
        "text": (text, {}, "not an ONNX model"),
        "no metadata": (with_metadata(tmp / "nometa.onnx", window=None, classes=None), {}, "metadata"),
        "three classes named": (with_metadata(tmp / "three.onnx", classes="still,forward,left"), {},
                                "classes must be"),
        "three outputs": (three_class_model(tmp / "out3.onnx"), {}, "one output"),
        "card does not match": (with_metadata(tmp / "ok.onnx", note="x"), {"card": {"window": 16}},
                                "card does not match"),
        "features unknown": (with_metadata(tmp / "v9.onnx", features="v9"), {}, "features"),
    }  # fmt: skip


CASES = ["text", "no metadata", "three classes named", "three outputs", "card does not match",
         "features unknown"]  # fmt: skip


@pytest.mark.parametrize("case", CASES)
def test_a_bad_model_file_is_refused_and_nothing_changes(
    client: TestClient, tmp_path: Path, case: str
) -> None:
    folder = client.app.state.models.folder  # type: ignore[attr-defined]
    before = _state(client, folder)
    path, extra, message = _bad_files(tmp_path)[case]
    r = _upload(client, path, **extra)
    assert 400 <= r.status_code < 500, r.text
    assert message in r.json()["detail"], r.json()
    assert _state(client, folder) == before, "a refused model must leave the registry and its folder alone"


def test_not_base64_and_a_duplicate_are_refused(client: TestClient, tmp_path: Path) -> None:
    r = client.post("/api/v1/models", json={"name": "x", "onnx_base64": "@@@"})
    assert r.status_code == 422 and "base64" in r.text
    r = _upload(client, DEFAULT_MODEL_PATH)
    assert r.status_code == 409 and "already registered as model 1" in r.json()["detail"], r.text
    assert len(client.get("/api/v1/models").json()) == 1


def test_activate_then_roll_back_and_the_session_log_names_the_model(
    client: TestClient, tmp_path: Path
) -> None:
    other = with_metadata(tmp_path / "other.onnx", note="a second model")
    r = _upload(client, other, card={"window": 32, "fps": 30, "features": "v2"}, card_md="# Model card\n",
                notes="for the test")  # fmt: skip
    assert r.status_code == 201, r.text
    new = r.json()
    assert new["kind"] == "uploaded" and not new["active"]
    assert new["card"]["metadata"]["note"] == "a second model"
    stored = Path(client.app.state.models.active()["file"])  # type: ignore[attr-defined]
    assert stored == DEFAULT_MODEL_PATH, "a registered model is not active until activated"

    r = client.post(f"/api/v1/models/{new['id']}/activate")
    assert r.status_code == 200 and r.json()["active"], r.text
    config = client.app.state.models.recognition_config()  # type: ignore[attr-defined]
    assert config.model_path != DEFAULT_MODEL_PATH and config.model_path.read_bytes() == other.read_bytes()
    assert [m["id"] for m in client.get("/api/v1/models").json() if m["active"]] == [new["id"]]

    p = client.post("/api/v1/participants", json={"code": "P07"}).json()
    s = client.post("/api/v1/sessions", json={"participant_id": p["id"], "condition": "CC"}).json()
    assert client.post(f"/api/v1/sessions/{s['id']}/start").status_code == 200
    events = client.get(f"/api/v1/sessions/{s['id']}/events").json()
    start = next(e for e in events if e["kind"] == "session" and e["payload"]["state"] == "running")
    assert start["payload"]["action_model_id"] == new["id"], start
    assert start["payload"]["action_model_sha256"] == new["sha256"]

    r = client.post("/api/v1/models/rollback")
    assert r.status_code == 200 and r.json()["kind"] == "base" and r.json()["active"], r.text
    r = client.post("/api/v1/models/rollback")  # back again: the one active before the base
    assert r.json()["id"] == new["id"]


def test_activation_of_a_changed_or_unknown_model_is_refused(client: TestClient, tmp_path: Path) -> None:
    new = _upload(client, with_metadata(tmp_path / "m.onnx", note="y")).json()
    folder: Path = client.app.state.models.folder  # type: ignore[attr-defined]
    (folder / new["uid"] / "action.onnx").write_bytes(b"changed")  # altered on disk after registering
    r = client.post(f"/api/v1/models/{new['id']}/activate")
    assert r.status_code == 409 and "changed since it was registered" in r.json()["detail"], r.text
    assert client.get("/api/v1/models/active").json()["kind"] == "base", "the active model must not change"
    assert client.post("/api/v1/models/999/activate").status_code == 404
    assert client.post("/api/v1/models/rollback").status_code == 409
