"""The database schema comes from Alembic, and an older database upgrades in place on start-up."""

from __future__ import annotations

import sqlite3
from pathlib import Path

from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext
from fastapi.testclient import TestClient

from app.core.config import Settings
from app.db.engine import make_engine
from app.db.migrate import current_revision, head_revision, upgrade
from app.db.models import Base
from app.main import create_app


def test_migrations_build_exactly_the_orm_schema(tmp_path: Path) -> None:
    engine = make_engine(tmp_path / "fresh.db")
    upgrade(engine)
    with engine.connect() as conn:
        diff = compare_metadata(MigrationContext.configure(conn), Base.metadata)
    engine.dispose()
    assert diff == [], f"migrations and ORM models disagree: {diff}"


def test_database_at_first_revision_upgrades_on_start_with_rows_intact(
    tmp_path: Path, app_settings: Settings
) -> None:
    db_path = app_settings.paths.db
    engine = make_engine(db_path)
    upgrade(engine, "0001_initial")
    assert current_revision(engine) == "0001_initial"
    engine.dispose()
    con = sqlite3.connect(db_path)
    con.execute(
        "INSERT INTO participants (code, first_condition, notes, created_at) "
        "VALUES ('OLD1', 'EC', 'from v1', '2026-01-02 10:00:00')"
    )
    con.execute(
        "INSERT INTO study_sessions (participant_id, condition, planned_index, status, notes, created_at) "
        "VALUES (1, 'EC', 1, 'stopped', 'first', '2026-01-02 10:05:00')"
    )
    con.execute(
        "INSERT INTO events (session_id, ts, kind, payload) VALUES (1, 1767348300.5, 'action', "
        '\'{"label": "forward"}\')'
    )
    con.commit()
    indexes_before = {r[1] for r in con.execute("PRAGMA index_list('events')")}
    con.close()
    assert "ix_events_ts" not in indexes_before

    with TestClient(create_app(app_settings, pipeline_factory=None)) as c:
        participants = c.get("/api/v1/participants").json()
        session = c.get("/api/v1/sessions/1").json()
        events = c.get("/api/v1/sessions/1/events").json()

    assert [(p["code"], p["first_condition"], p["notes"]) for p in participants] == [
        ("OLD1", "EC", "from v1")
    ]
    assert session["status"] == "stopped" and session["notes"] == "first"
    assert [(e["kind"], e["payload"], e["ts"]) for e in events] == [
        ("action", {"label": "forward"}, 1767348300.5)
    ]
    engine = make_engine(db_path)
    assert current_revision(engine) == head_revision()
    engine.dispose()
    con = sqlite3.connect(db_path)
    assert "ix_events_ts" in {r[1] for r in con.execute("PRAGMA index_list('events')")}
    assert con.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    con.close()
