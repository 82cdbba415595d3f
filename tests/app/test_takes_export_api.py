"""Exporting a take over the API (the app on a real SQLite file, a real take folder in its takes
folder): zip, TRC and labels downloads; a damaged take, a bad format or user refused with one
message and nothing stored changed."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient

from app.core.config import Settings
from app.db.engine import make_engine, make_session_factory
from app.db.take_repository import create_take, finish_take_row
from app.main import create_app
from tests.app.conftest import make_settings
from tests.app.takes_fixture import FRAMES_N, NAVIGATOR, OTHER, joints_of, make_take, snapshot


@pytest.fixture()
def indexed(client: TestClient, app_settings: Settings) -> tuple[int, Path]:
    folder = app_settings.paths.db.parent / "takes" / "tiny-take"
    manifest = make_take(folder)
    engine = make_engine(app_settings.paths.db)
    try:
        with make_session_factory(engine)() as db:
            row = create_take(
                db,
                uid="tiny-take",
                folder=str(folder),
                status="recording",
                files={},
                participant_code="T01",
                protocol="tiny",
                source="simulator",
                notes="",
            )
            finish_take_row(db, row.id, manifest, "complete")
            return row.id, folder
    finally:
        engine.dispose()


def test_a_take_downloads_as_zip_trc_and_labels(client: TestClient, indexed: tuple[int, Path]) -> None:
    take_id, folder = indexed
    r = client.get(f"/api/v1/takes/{take_id}/export")
    assert r.status_code == 200 and r.headers["content-type"] == "application/zip", r.text[:300]
    assert 'filename="tiny-take.zip"' in r.headers["content-disposition"]
    with zipfile.ZipFile(io.BytesIO(r.content)) as zf:
        assert zf.read("tiny-take/skeletons.npz") == (folder / "skeletons.npz").read_bytes()
        assert f"tiny-take/trc/tiny-take_P{NAVIGATOR}.trc" in zf.namelist()
    r = client.get(f"/api/v1/takes/{take_id}/export", params={"format": "trc"})
    assert (
        r.status_code == 200 and f'filename="tiny-take_P{NAVIGATOR}.trc"' in r.headers["content-disposition"]
    )
    lines = r.text.splitlines()
    assert lines[0].startswith("PathFileType\t4\t(X/Y/Z)") and len(lines) == 5 + FRAMES_N
    r = client.get(f"/api/v1/takes/{take_id}/export", params={"format": "labels"})
    assert r.status_code == 200 and r.text.startswith("take,participant_code,user_id,frame,t_s,label")
    assert len(r.text.splitlines()) == 1 + FRAMES_N


@pytest.mark.parametrize(
    ("params", "damage", "status", "match"),
    [
        ({}, "frames.jsonl", 400, "is damaged: frames.jsonl is missing; nothing was exported"),
        ({"format": "trc"}, "skeletons.npz", 400, "skeletons.npz is missing"),
        ({"format": "gif"}, None, 422, "format"),
        ({"format": "zip", "user_id": 3}, None, 422, "user_id is for format=trc"),
        ({"format": "trc", "user_id": 42}, None, 422, "has no user 42"),
    ],
)
def test_bad_exports_are_refused_and_change_nothing(
    client: TestClient, indexed: tuple[int, Path], params: dict, damage: str | None, status: int, match: str
) -> None:
    take_id, folder = indexed
    if damage:
        (folder / damage).unlink()
    row_before = client.get(f"/api/v1/takes/{take_id}").json()
    files_before = snapshot(folder.parent)
    r = client.get(f"/api/v1/takes/{take_id}/export", params=params)
    assert r.status_code == status and match in r.text, r.text
    assert client.get(f"/api/v1/takes/{take_id}").json() == row_before
    assert snapshot(folder.parent) == files_before


def test_an_unknown_take_is_404(client: TestClient) -> None:
    r = client.get("/api/v1/takes/4242/export")
    assert r.status_code == 404 and "4242" in r.json()["detail"]


@pytest.mark.parametrize("damage", ["frames.jsonl", "calibration-changed"])
def test_labels_of_a_damaged_take_are_not_edited(
    client: TestClient, indexed: tuple[int, Path], damage: str
) -> None:
    take_id, folder = indexed
    if damage == "frames.jsonl":
        (folder / "frames.jsonl").unlink()
        match = "frames.jsonl is missing"
    else:
        with (folder / "frames.jsonl").open("a") as f:
            f.write("\n")
        match = "frames.jsonl does not match its sha256"
    spans = client.get(f"/api/v1/takes/{take_id}/labels").json()["spans"]
    before = snapshot(folder)
    edited = [{**spans[0], "label": "left"}, *spans[1:]]
    r = client.put(f"/api/v1/takes/{take_id}/labels", json={"spans": edited})
    detail = r.json()["detail"]
    assert r.status_code == 400 and match in detail and "not changed" in detail, r.text
    assert snapshot(folder) == before


def test_a_take_replays_in_the_3d_view_in_place_of_the_live_people(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    settings = make_settings(tmp_path, viser=True)
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        viewer = c.app.state.viewer  # type: ignore[attr-defined]
        folder = settings.paths.db.parent / "takes" / "tiny-take"
        _index(settings, folder)
        r = c.put("/api/v1/takes/1/replay", json={"t_s": 0.33})
        assert r.status_code == 200, r.text
        got = r.json()
        assert (got["index"], got["frame"], got["users"], got["navigator"]) == (6, 106, [3, 5], 3), got
        assert sorted(viewer.people) == [3, 5]
        shown = np.asarray(viewer.people[OTHER].joints.points)
        np.testing.assert_allclose(shown, joints_of(OTHER, 6), atol=1e-3)  # viser keeps float16
        assert viewer.arrow is not None and viewer.arrow.visible, "the navigator's arrow"
        viewer.update({"extra": {"people3d": [{"user_id": 9, "joints": joints_of(9, 0).tolist()}]}})
        assert sorted(viewer.people) == [3, 5], "live updates wait while the take replays"
        assert c.delete("/api/v1/takes/replay").status_code == 204
        viewer.update({"extra": {"people3d": [{"user_id": 9, "joints": joints_of(9, 0).tolist()}]}})
        assert sorted(viewer.people) == [9], "back to the live people"
        for body, status, match in [({"t_s": -1}, 422, "t_s"), ({"t": 1}, 422, "t_s")]:
            r = c.put("/api/v1/takes/1/replay", json=body)
            assert r.status_code == status and match in r.text, r.text
        assert c.put("/api/v1/takes/99/replay", json={"t_s": 0}).status_code == 404


def test_replay_without_a_3d_view_is_409(client: TestClient, indexed: tuple[int, Path]) -> None:
    r = client.put(f"/api/v1/takes/{indexed[0]}/replay", json={"t_s": 0.1})
    assert r.status_code == 409 and "3D view is off" in r.json()["detail"], r.text


def _index(settings: Settings, folder: Path) -> int:
    manifest = make_take(folder)
    engine = make_engine(settings.paths.db)
    try:
        with make_session_factory(engine)() as db:
            row = create_take(
                db,
                uid="tiny-take",
                folder=str(folder),
                status="recording",
                files={},
                participant_code="T01",
                protocol="tiny",
                source="simulator",
                notes="",
            )
            finish_take_row(db, row.id, manifest, "complete")
            return row.id
    finally:
        engine.dispose()
