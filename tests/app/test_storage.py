"""Free disk space where the server writes (app/services/storage.py): the live status says how much
is left; below ``storage.min_free_gb`` a take being recorded stops (and is kept), new takes and
backups are refused with the reason, and the event log says when the level changed.

The disk is real: thresholds are set against this machine's real free space, and the take test
takes space away with a real file (``posix_fallocate``: the blocks are reserved at once, without
writing gigabytes)."""

from __future__ import annotations

import sqlite3
import time
from pathlib import Path

import httpx
import pytest
from fastapi.testclient import TestClient

from app.core.config import Settings, StorageSettings
from app.db.errors import StateConflict
from app.main import create_app
from app.services.storage import StorageWatch
from tests.app.conftest import Served, make_settings
from tests.disk import free_gb, need_free_gb, take_space
from tests.waiting import wait_until


def _with_storage(settings: Settings, **storage: float) -> Settings:
    return settings.model_copy(update={"storage": settings.storage.model_copy(update=storage)})


def test_levels_follow_the_real_free_space_and_each_change_is_acted_on_once(tmp_path: Path) -> None:
    free = free_gb(tmp_path)
    calls: list[str] = []
    changes: list[int] = []
    watch = StorageWatch(
        {"database": tmp_path / "db-folder", "takes": tmp_path / "takes" / "deeper"},
        StorageSettings(warn_free_gb=free * 10, min_free_gb=0),
        on_change=lambda: changes.append(1),
    )
    watch.on_full(calls.append)
    low = watch.check()
    assert low["level"] == "low" and abs(low["free_gb"] - free) < 1.0 and "warn_free_gb" in low["message"]
    assert low["path"] == str(tmp_path)  # the nearest folder that exists: where the files will go
    watch.require("a take")  # low is a warning only
    watch.settings = StorageSettings(warn_free_gb=free * 10, min_free_gb=free * 5)
    full = watch.check()
    assert full["level"] == "full" and "nearly full" in full["message"] and calls == [full["message"]]
    watch.check()
    assert calls == [full["message"]] and len(changes) == 2  # once per change of level
    with pytest.raises(StateConflict, match="a take refused: the disk is nearly full"):
        watch.require("a take")
    watch.settings = StorageSettings(warn_free_gb=0, min_free_gb=0)
    assert watch.check()["level"] == "ok" and watch.current()["message"] == "" and len(changes) == 3


def test_the_settings_refuse_a_warning_below_the_minimum() -> None:
    with pytest.raises(ValueError, match="warn_free_gb"):
        StorageSettings(warn_free_gb=1, min_free_gb=2)


def test_a_full_disk_refuses_takes_and_backups_and_the_status_says_why(tmp_path: Path) -> None:
    settings = _with_storage(make_settings(tmp_path), warn_free_gb=1e6, min_free_gb=1e6)
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        storage = c.get("/api/v1/status").json()["storage"]
        assert storage["level"] == "full" and storage["free_gb"] > 0 and "nearly full" in storage["message"]
        r = c.post("/api/v1/takes", json={"duration_s": 5})
        assert r.status_code == 409 and "a new take refused: the disk is nearly full" in r.json()["detail"]
        r = c.post("/api/v1/backups")
        assert r.status_code == 503 and "a backup refused" in r.json()["detail"]
        assert c.post("/api/v1/participants", json={"code": "P01"}).status_code == 201  # the study goes on
    assert not (tmp_path / "backups").exists() and not (tmp_path / "takes").exists()
    con = sqlite3.connect(settings.paths.db)
    kinds = [r[0] for r in con.execute("SELECT payload FROM events WHERE kind = 'storage'")]
    con.close()
    assert len(kinds) == 1 and '"full"' in kinds[0]


@pytest.mark.slow
def test_a_take_stops_and_is_kept_when_the_disk_fills_up(tmp_path: Path, disk_alone: None) -> None:
    """A real file takes 3 GB away while a take records; the take stops within a few checks and is
    kept complete; the dashboard's status says the disk is full; freeing the space clears it."""
    free = need_free_gb(tmp_path, 8)
    settings = _with_storage(
        make_settings(tmp_path), warn_free_gb=free - 1.5, min_free_gb=free - 1.5, check_s=0.2
    )
    ballast = tmp_path / "ballast.bin"
    with Served(settings) as served:
        base = f"{served.base}/api/v1"
        served.wait_status(lambda st: st["state"] == "running", 60)
        assert served.wait_status(lambda st: st["storage"]["free_gb"] is not None)["storage"]["level"] == "ok"
        take = httpx.post(f"{base}/takes", json={"duration_s": 120, "participant_code": "P09"})
        assert take.status_code == 201, take.text
        time.sleep(1.0)
        take_space(ballast, 3 * 10**9)
        url = f"{base}/takes/{take.json()['id']}"

        def stopped() -> dict | None:
            row: dict = httpx.get(url).json()
            return row if row["status"] != "recording" else None

        row = wait_until(stopped, "the take to stop on the full disk", timeout_s=30)
        assert row["status"] == "complete" and 0.5 < row["duration_s"] < 30, row
        status = served.wait_status(lambda st: st["storage"]["level"] == "full")
        assert "nearly full" in status["storage"]["message"]
        again = httpx.post(f"{base}/takes", json={"duration_s": 5})
        assert again.status_code == 409 and "nearly full" in again.json()["detail"]
        ballast.unlink()
        served.wait_status(lambda st: st["storage"]["level"] == "ok")
    con = sqlite3.connect(settings.paths.db)
    stopping = [r[0] for r in con.execute("SELECT payload FROM events WHERE kind = 'take'")]
    levels = [r[0] for r in con.execute("SELECT payload FROM events WHERE kind = 'storage'")]
    con.close()
    assert any('"stopping"' in p and "nearly full" in p for p in stopping), stopping
    assert ['"full"' in p for p in levels] == [True, False], levels
