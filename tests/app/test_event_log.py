"""The event writer batches events into SQLite and loses at most the last second."""

from __future__ import annotations

import sqlite3
import threading
from pathlib import Path

import pytest

from app.db.engine import make_engine, make_session_factory
from app.db.migrate import upgrade
from app.services.event_log import EventWriter, EventWriterConfig
from tests.waiting import wait_until


@pytest.fixture()
def db_path(tmp_path: Path) -> Path:
    path = tmp_path / "events.db"
    engine = make_engine(path)
    upgrade(engine)
    engine.dispose()
    return path


def count_rows(path: Path) -> int:
    """Read with a separate connection, as another process (or a restart after a crash) would."""
    con = sqlite3.connect(path)
    try:
        return int(con.execute("SELECT count(*) FROM events").fetchone()[0])
    finally:
        con.close()


@pytest.mark.parametrize("flush_s", [0.0, 1.5])
def test_config_rejects_intervals_outside_the_one_second_bound(flush_s: float) -> None:
    with pytest.raises(ValueError, match="flush_interval_s"):
        EventWriterConfig(flush_interval_s=flush_s)


def test_events_reach_the_file_on_the_flush_clock_without_close(db_path: Path) -> None:
    engine = make_engine(db_path)
    writer = EventWriter(make_session_factory(engine), EventWriterConfig(flush_interval_s=0.3))
    writer.start()
    try:
        for i in range(120):  # two seconds of 60 Hz action events, recorded at once
            writer.record("action", {"label": "forward", "i": i})
        # The writer flushes on its own clock (0.3 s here), with no close() and no further record():
        # the rows appear. How soon is the flush interval's business, measured on a quiet machine,
        # not asserted on this one's wall clock (a loaded CI machine stalls a thread for seconds).
        wait_until(lambda: count_rows(db_path) >= 120, "the 120 events on disk without close()")
        assert count_rows(db_path) == 120
    finally:
        writer.close()
        engine.dispose()


def test_many_producers_are_written_in_few_batches_and_close_writes_the_rest(db_path: Path) -> None:
    engine = make_engine(db_path)
    factory = make_session_factory(engine)
    batches: list[int] = []

    def counting_factory():  # type: ignore[no-untyped-def]
        batches.append(1)
        return factory()

    writer = EventWriter(counting_factory, EventWriterConfig(flush_interval_s=1.0, max_batch=5000))
    writer.start()

    def produce(k: int) -> None:
        for i in range(500):
            writer.record("action", {"producer": k, "i": i})

    threads = [threading.Thread(target=produce, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    writer.close()
    engine.dispose()
    assert count_rows(db_path) == 2000
    assert writer.written == 2000 and writer.failed == 0
    assert len(batches) <= 5, f"2000 events should go in a handful of transactions, took {len(batches)}"


def test_events_carry_the_running_session(db_path: Path) -> None:
    engine = make_engine(db_path)
    con = sqlite3.connect(db_path)
    con.execute("INSERT INTO participants (code, notes, created_at) VALUES ('P1', '', '2026-01-01')")
    con.execute(
        "INSERT INTO study_sessions (participant_id, condition, status, notes, created_at) "
        "VALUES (1, 'CC', 'running', '', '2026-01-01')"
    )
    con.commit()
    writer = EventWriter(make_session_factory(engine))
    writer.start()
    writer.record("pipeline", {"state": "running"})
    writer.set_session(1, since_ts=1000.0)
    writer.record("navigator", {"current": 2}, ts=999.5)  # happened before the start, reported after
    writer.record("action", {"label": "left"}, ts=1000.0)
    writer.set_session(None)
    writer.record("pipeline", {"state": "stopped"})
    assert writer.flush()
    rows = con.execute("SELECT session_id, kind, ts FROM events ORDER BY id").fetchall()
    writer.close()
    engine.dispose()
    con.close()
    assert [(r[0], r[1]) for r in rows] == [
        (None, "pipeline"),
        (None, "navigator"),
        (1, "action"),
        (None, "pipeline"),
    ]
    assert rows[2][2] == 1000.0
