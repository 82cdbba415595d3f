"""Exporting a take over the API (the app on a real SQLite file, a real take folder in its takes
folder): zip, TRC and labels downloads; a damaged take, a bad format or user refused with one
message and nothing stored changed."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.core.config import Settings
from app.db.engine import make_engine, make_session_factory
from app.db.take_repository import create_take, finish_take_row
from tests.app.takes_fixture import FRAMES_N, NAVIGATOR, make_take, snapshot


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
