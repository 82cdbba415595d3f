"""POST /models/train refuses what cannot be trained on, before any worker starts (issue 18 items 4, 7);
the job itself runs from the dashboard in tests/e2e/test_models_panel.py."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from tests.app.models.takes_data import index_takes, unlabelled_take


def test_training_requests_that_cannot_run_are_refused(
    client: TestClient, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with client.app.state.session_factory() as db:  # type: ignore[attr-defined]
        (bare,) = index_takes(db, [unlabelled_take(tmp_path / "takes")])
    r = client.post("/api/v1/models/train", json={"take_ids": [bare], "epochs": 1})
    assert r.status_code == 422, r.text
    assert f"take {bare}: take take-P1-s5 has no labels" in r.json()["detail"], r.text
    r = client.post("/api/v1/models/train", json={"take_ids": [99], "epochs": 1})
    assert r.status_code == 404 and "take 99 not found" in r.json()["detail"], r.text
    r = client.post("/api/v1/models/train", json={"take_ids": [], "epochs": 1})
    assert r.status_code == 422
    monkeypatch.setitem(sys.modules, "torch", None)  # as when the train extra is not installed
    r = client.post("/api/v1/models/train", json={"take_ids": [bare], "epochs": 1})
    assert r.status_code == 400 and "pip install 'cavewalk[train]'" in r.json()["detail"], r.text
    assert client.get("/api/v1/models/train").json() == [], "no job may start"
    assert len(client.get("/api/v1/models").json()) == 1
