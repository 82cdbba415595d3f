"""Teach through the API: a participant's teach take adapts the active model, the report gives accuracy
before/after on the held-back part, the adaptation applies to that participant's sessions only, can
be switched off, and is written to the session's log (issue 18 item 3)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient

from pipeline.takes.teach import OutputAdaptation
from tests.app.models.takes_data import index_takes, simulated_takes, teach_take, unlabelled_take


def _index(client: TestClient, folders: list[Path]) -> list[int]:
    with client.app.state.session_factory() as db:  # type: ignore[attr-defined]
        return index_takes(db, folders)


def _session(client: TestClient, code: str) -> int:
    p = client.post("/api/v1/participants", json={"code": code}).json()
    return int(
        client.post("/api/v1/sessions", json={"participant_id": p["id"], "condition": "CC"}).json()["id"]
    )


def _start_event(client: TestClient, sid: int) -> dict[str, Any]:
    assert client.post(f"/api/v1/sessions/{sid}/start").status_code == 200
    events = client.get(f"/api/v1/sessions/{sid}/events").json()
    return next(e["payload"] for e in events if e["kind"] == "session" and e["payload"]["state"] == "running")


def test_teach_adapts_to_one_participant_and_their_sessions_only(client: TestClient, tmp_path: Path) -> None:
    (take,) = _index(client, [teach_take(tmp_path, "P1")])
    r = client.post("/api/v1/models/teach", json={"take_id": take})
    assert r.status_code == 201, r.text
    a = r.json()
    rep = a["report"]
    assert a["participant_code"] == "P1" and a["model_id"] == 1 and a["method"] == "affine-logp"
    assert 0.0 <= rep["before"]["accuracy"] <= 1.0 and 0.0 <= rep["after"]["accuracy"] <= 1.0, rep
    assert rep["holdout_frames"] > 300 and rep["fit_frames"] > rep["holdout_frames"], rep
    assert 35.0 < rep["split_s"] < 45.0, "the last third of the 60 s teach take is held back"
    assert a["enabled"] == (rep["after"]["accuracy"] >= rep["before"]["accuracy"]) == rep["helps"]
    a = client.patch(f"/api/v1/models/adaptations/{a['id']}", json={"enabled": True}).json()
    pipeline = client.app.state.pipeline  # type: ignore[attr-defined]

    s1, s2 = _session(client, "P1"), _session(client, "P2")
    start = _start_event(client, s1)
    assert start["teach_adaptation_id"] == a["id"] and start["teach_after"] == rep["after"]["accuracy"], start
    on = pipeline.adaptation
    assert isinstance(on, OutputAdaptation) and on.participant_code == "P1" and on.adaptation_id == a["id"]
    # switched off while the session runs: off at once, and the session's log says so
    assert (
        client.patch(f"/api/v1/models/adaptations/{a['id']}", json={"enabled": False}).json()["enabled"]
        is False
    )
    assert pipeline.adaptation is None
    client.app.state.events.flush()  # type: ignore[attr-defined]
    kinds = [
        (e["kind"], e["payload"].get("state")) for e in client.get(f"/api/v1/sessions/{s1}/events").json()
    ]
    assert ("adaptation", "switched off") in kinds, kinds
    client.patch(f"/api/v1/models/adaptations/{a['id']}", json={"enabled": True})
    assert pipeline.adaptation is not None, "switched on again during P1's session"
    assert client.post(f"/api/v1/sessions/{s1}/stop").status_code == 200
    assert pipeline.adaptation is None, "the adaptation ends with the participant's session"

    start = _start_event(client, s2)
    assert start["teach_adaptation_id"] is None and pipeline.adaptation is None, (
        "P2 never gets P1's adaptation"
    )
    assert [x["id"] for x in client.get("/api/v1/models/adaptations?participant_code=P1").json()] == [a["id"]]


def test_takes_that_cannot_teach_are_refused_and_nothing_is_stored(
    client: TestClient, tmp_path: Path
) -> None:
    (bare,) = _index(client, [unlabelled_take(tmp_path / "bare")])
    r = client.post("/api/v1/models/teach", json={"take_id": bare})
    assert r.status_code == 422 and "has no labels" in r.json()["detail"], r.text
    (short,) = _index(client, simulated_takes(tmp_path / "short", participants=1, duration_s=6.0, seed=3))
    r = client.post("/api/v1/models/teach", json={"take_id": short})
    assert r.status_code == 422, r.text
    assert client.post("/api/v1/models/teach", json={"take_id": 77}).status_code == 404
    assert client.get("/api/v1/models/adaptations").json() == []
