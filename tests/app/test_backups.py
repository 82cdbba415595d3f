"""Backups of the study database (app/db/backup.py, app/services/backup.py, ``cavewalk db``): copies
taken while the server writes hold a consistent prefix of what it wrote and pass SQLite's check;
the server backs up before a migration, when a session ends, while the data changes, at stop and
after a kill; a restore puts a backup back only when no server uses the database, keeping the
database it replaces. Real SQLite files, the real app (TestClient), the real command line."""

from __future__ import annotations

import hashlib
import sqlite3
import subprocess
import sys
import threading
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
from fastapi.testclient import TestClient

from app.core.config import Settings
from app.db.backup import (
    BackupError,
    backup_database,
    inspect_database,
    list_backups,
    new_backup_path,
    prune_backups,
    restore_database,
)
from app.db.engine import lock_path, make_engine
from app.db.migrate import head_revision, prepare_database, upgrade
from app.main import create_app
from pipeline.errors import ConfigError
from tests.app.conftest import make_settings, older_database
from tests.app.test_cli_errors import run_cli
from tests.waiting import wait_until


def _db(tmp_path: Path, codes: tuple[str, ...] = ()) -> Path:
    db = tmp_path / "study.db"
    prepare_database(db)
    con = sqlite3.connect(db)
    with con:
        for code in codes:
            con.execute(
                "INSERT INTO participants (code, notes, created_at) VALUES (?, '', ?)",
                (code, datetime.now(UTC).replace(tzinfo=None)),
            )
    con.close()
    return db


def _write(db: Path, sql: str) -> None:
    con = sqlite3.connect(db)
    with con:
        con.execute(sql)
    con.close()


def _codes(db: Path) -> list[str]:
    con = sqlite3.connect(f"file:{db}?mode=ro", uri=True)
    try:
        return [r[0] for r in con.execute("SELECT code FROM participants ORDER BY code")]
    finally:
        con.close()


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _with_backups(settings: Settings, **backup: object) -> Settings:
    return settings.model_copy(update={"backup": settings.backup.model_copy(update=backup)})


# -- the copies ---------------------------------------------------------------------------------


def test_backups_taken_while_a_writer_commits_hold_a_consistent_prefix(tmp_path: Path) -> None:
    db = _db(tmp_path)
    stop, errors, written = threading.Event(), [], [0]

    def writer() -> None:  # the event log's pattern: small transactions, as fast as they go
        con = sqlite3.connect(db, timeout=10)
        con.execute("PRAGMA journal_mode=WAL")
        try:
            while not stop.is_set():
                with con:
                    for _ in range(20):
                        written[0] += 1
                        con.execute(
                            "INSERT INTO events (ts, kind, payload) VALUES (?, 'action', ?)",
                            (float(written[0]), f'{{"n": {written[0]}}}'),
                        )
        except sqlite3.Error as exc:  # a backup that blocked the writer would show here
            errors.append(exc)
        finally:
            con.close()

    thread = threading.Thread(target=writer)
    thread.start()
    try:
        wait_until(lambda: written[0] > 200, "the writer to commit")
        infos = []
        for i in range(3):
            infos.append(backup_database(db, tmp_path / f"b{i}.db"))
            target = written[0] + 200
            wait_until(lambda: written[0] > target, "more commits after the backup")  # noqa: B023
    finally:
        stop.set()
        thread.join()
    assert errors == []
    counts = [b.counts["events"] for b in infos]
    assert counts[0] > 0 and counts == sorted(counts) and len(set(counts)) == 3, counts
    for b in infos:
        con = sqlite3.connect(b.path)
        ids = [r[0] for r in con.execute("SELECT id FROM events ORDER BY id")]
        ts = [r[0] for r in con.execute("SELECT ts FROM events ORDER BY id")]
        assert con.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        assert con.execute("PRAGMA journal_mode").fetchone()[0] == "delete"  # one self-contained file
        con.close()
        # whole transactions only, in order: events 1..n and nothing after (a multiple of 20)
        assert ids == list(range(1, len(ids) + 1)) and ts == [float(i) for i in ids] and len(ids) % 20 == 0
        assert b.revision == head_revision()
    assert not list(tmp_path.glob("*.part"))


def test_a_bad_source_or_target_is_one_error_and_writes_nothing(tmp_path: Path) -> None:
    db = _db(tmp_path, ("P01",))
    out = tmp_path / "out"
    foreign = tmp_path / "foreign.db"
    sqlite3.connect(foreign).execute("CREATE TABLE t (x)").connection.close()
    damaged = tmp_path / "damaged.db"
    damaged.write_bytes(db.read_bytes()[: db.stat().st_size // 2] + b"\x13" * 5000)
    text = tmp_path / "notes.db"
    text.write_text("not a database")
    for source, message in (
        (tmp_path / "none.db", "not found"),
        (foreign, "not a cavewalk database"),
        (text, "not a readable SQLite database"),
        (damaged, "damaged|not a readable"),
    ):
        with pytest.raises(BackupError, match=message):
            backup_database(source, out / "b.db")
        assert not out.exists() or list(out.iterdir()) == []
    existing = tmp_path / "existing.db"
    existing.write_bytes(b"keep me")
    with pytest.raises(BackupError, match="already exists"):
        backup_database(db, existing)
    assert existing.read_bytes() == b"keep me"
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    with pytest.raises(BackupError, match="cannot create the backup folder"):
        backup_database(db, blocker / "b.db")


def test_pruning_keeps_the_newest_of_this_database_and_nothing_else_is_touched(tmp_path: Path) -> None:
    db = _db(tmp_path)
    folder = tmp_path / "backups"
    t0 = datetime(2026, 12, 7, 9, 0, tzinfo=UTC)
    made = [
        backup_database(db, new_backup_path(folder, db, r, t0 + timedelta(minutes=i))).path
        for i, r in enumerate(("start", "auto", "session-end", "auto", "stop"))
    ]
    same_second = backup_database(db, new_backup_path(folder, db, "manual", t0 + timedelta(minutes=4))).path
    other = folder / "other-20261207-080000-auto.db"
    other.write_bytes(b"another database's backup")
    notes = folder / "notes.txt"
    notes.write_text("mine")
    listed = [b.path for b in list_backups(folder, db)]
    assert listed == [same_second, made[4], made[3], made[2], made[1], made[0]]
    assert same_second.name == "study-20261207-090400-1-manual.db"
    removed = prune_backups(folder, db, keep=2)
    assert sorted(removed) == sorted(made[:4])
    assert sorted(folder.iterdir()) == sorted([same_second, made[4], other, notes])


def test_every_commit_of_the_app_is_synced_to_disk(tmp_path: Path) -> None:
    """WAL with synchronous=FULL: a power cut loses no committed transaction (NORMAL may)."""
    engine = make_engine(_db(tmp_path))
    try:
        with engine.connect() as conn:
            assert conn.exec_driver_sql("PRAGMA journal_mode").scalar() == "wal"
            assert conn.exec_driver_sql("PRAGMA synchronous").scalar() == 2  # FULL
    finally:
        engine.dispose()


# -- restore -------------------------------------------------------------------------------------


def test_restore_puts_a_backup_back_and_keeps_the_database_it_replaces(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    db = _db(tmp_path, ("P01",))
    monkeypatch.setenv("CAVEWALK_PATHS__DB", str(db))
    assert run_cli(["db", "backup"], monkeypatch) == 0
    (first,) = list_backups(tmp_path / "backups", db)
    assert "1 participants" in capsys.readouterr().out
    _write(db, "INSERT INTO participants (code, notes, created_at) VALUES ('P02', '', '2026-12-07')")
    assert run_cli(["db", "restore", first.path.name], monkeypatch) == 0  # a name in the backup folder
    out = capsys.readouterr().out
    assert _codes(db) == ["P01"]
    (safety,) = [b for b in list_backups(tmp_path / "backups", db) if b.reason == "before-restore"]
    assert f"kept as {safety.path}" in out
    assert _codes(safety.path) == ["P01", "P02"]
    assert run_cli(["db", "backups"], monkeypatch) == 0
    listing = capsys.readouterr().out
    assert "2 backup(s)" in listing and first.path.name in listing and safety.path.name in listing


def test_a_damaged_database_is_restored_and_its_files_are_kept_as_they_were(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The case a restore is for: the database cannot be read any more (here its pages are
    overwritten); its files are kept byte for byte, WAL included, and the backup goes in place."""
    db = _db(tmp_path, ("P01",))
    backup = backup_database(db, tmp_path / "good.db").path
    _write(db, "INSERT INTO participants (code, notes, created_at) VALUES ('P02', '', '2026-12-07')")
    data = bytearray(db.read_bytes())
    data[4096:] = b"\x5a" * (len(data) - 4096)
    db.write_bytes(bytes(data))
    wal = db.with_name(db.name + "-wal")
    wal.write_bytes(b"the damaged database's WAL")
    with pytest.raises(BackupError):
        inspect_database(db)
    monkeypatch.setenv("CAVEWALK_PATHS__DB", str(db))
    assert run_cli(["db", "restore", str(backup)], monkeypatch) == 0, capsys.readouterr().err
    assert _codes(db) == ["P01"] and inspect_database(db)[0] == head_revision()
    assert not wal.exists() and not db.with_name(db.name + "-shm").exists()
    (kept,) = list_backups(tmp_path / "backups", db)
    assert kept.reason == "before-restore" and kept.path.read_bytes() == bytes(data)
    assert kept.path.with_name(kept.path.name + "-wal").read_bytes() == b"the damaged database's WAL"
    assert prune_backups(tmp_path / "backups", db, keep=1) == []
    assert sorted(p.name for p in (tmp_path / "backups").iterdir()) == [
        kept.path.name,
        kept.path.name + "-wal",
    ]


def test_restore_refuses_while_a_server_holds_the_database_and_changes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    db = _db(tmp_path, ("P01",))
    backup = backup_database(db, tmp_path / "b.db").path
    _write(db, "INSERT INTO participants (code, notes, created_at) VALUES ('P02', '', '2026-12-07')")
    before = _sha(db)
    holder = subprocess.Popen(  # another process holds the database's lock, as a running server does
        [
            sys.executable,
            "-c",
            "import sys, time; from pathlib import Path; from app.db.engine import DatabaseLock; "
            "DatabaseLock.acquire(Path(sys.argv[1])); print('held', flush=True); time.sleep(60)",
            str(db),
        ],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert holder.stdout is not None and holder.stdout.readline().strip() == "held"
        monkeypatch.setenv("CAVEWALK_PATHS__DB", str(db))
        assert run_cli(["db", "restore", str(backup)], monkeypatch) == 2
        err = capsys.readouterr().err
        assert err.count("error:") == 1 and f"PID {holder.pid}" in err
    finally:
        holder.kill()
        holder.wait()
    assert _sha(db) == before and _codes(db) == ["P01", "P02"]
    assert list_backups(tmp_path / "backups", db) == []  # no safety copy was made either
    assert lock_path(db).is_file()


def test_restore_refuses_bad_backups_before_touching_the_database(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    db = _db(tmp_path, ("P01",))
    newer = backup_database(db, tmp_path / "newer.db").path
    _write(newer, "UPDATE alembic_version SET version_num = '0099_from_the_future'")
    foreign = tmp_path / "foreign.db"
    sqlite3.connect(foreign).execute("CREATE TABLE t (x)").connection.close()
    before = _sha(db)
    monkeypatch.setenv("CAVEWALK_PATHS__DB", str(db))
    cases = (
        (newer, "a newer cavewalk made it"),
        (foreign, "not a cavewalk database"),
        (tmp_path / "missing.db", "backup not found"),
        (db, "the database itself"),
    )
    for bad, message in cases:
        assert run_cli(["db", "restore", str(bad)], monkeypatch) == 2
        err = capsys.readouterr().err
        assert err.count("error:") == 1 and message in err, err
    with pytest.raises(BackupError, match="newer cavewalk"):
        restore_database(newer, db, tmp_path / "backups")
    assert _sha(db) == before and list_backups(tmp_path / "backups", db) == []


# -- the server's own backups ---------------------------------------------------------------------


def _reasons(settings: Settings) -> list[str]:
    return [b.reason for b in list_backups(settings.paths.db.parent / "backups", settings.paths.db)]


def test_the_server_backs_up_before_a_migration_at_a_session_end_at_stop_and_after_a_kill(
    tmp_path: Path,
) -> None:
    settings = make_settings(tmp_path)
    db = older_database(settings.paths.db)
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        (before,) = list_backups(db.parent / "backups", db)
        assert before.reason == "before-upgrade" and inspect_database(before.path)[0] == "0001_initial"
        pid = c.get("/api/v1/participants").json()[0]["id"]
        sid = c.post("/api/v1/sessions", json={"participant_id": pid, "condition": "CC"}).json()["id"]
        c.post(f"/api/v1/sessions/{sid}/start")
        assert c.post(f"/api/v1/sessions/{sid}/stop").json()["status"] == "stopped"
        wait_until(lambda: "session-end" in _reasons(settings), "the session-end backup")
        end = next(b for b in list_backups(db.parent / "backups", db) if b.reason == "session-end")
        con = sqlite3.connect(end.path)
        assert con.execute("SELECT status FROM study_sessions").fetchall() == [("stopped",)]
        kinds = [r[0] for r in con.execute("SELECT kind FROM events WHERE session_id = ?", (sid,))]
        con.close()
        assert "session" in kinds  # the session's own events are in the copy
        listed = c.get("/api/v1/backups").json()
        assert [b["reason"] for b in listed["backups"]] == ["session-end", "before-upgrade"]
        assert listed["last"]["reason"] == "session-end" and listed["last_error"] is None
    assert _reasons(settings) == ["stop", "session-end", "before-upgrade"]
    with TestClient(create_app(settings, pipeline_factory=None)):
        assert _reasons(settings) == ["stop", "session-end", "before-upgrade"]  # unchanged since the stop
    assert _reasons(settings)[0] == "stop"
    n = len(_reasons(settings))
    _write(db, "INSERT INTO participants (code, notes, created_at) VALUES ('P02', '', '2026-12-07')")
    with TestClient(create_app(settings, pipeline_factory=None)):
        wait_until(lambda: "start" in _reasons(settings), "the start backup of what the killed server left")
        assert _reasons(settings)[0] == "start" and len(_reasons(settings)) == n + 1
        start = list_backups(db.parent / "backups", db)[0]
        assert _codes(start.path) == ["P01", "P02"]


def test_back_up_now_and_timed_backups_only_while_the_data_changes(tmp_path: Path) -> None:
    settings = _with_backups(make_settings(tmp_path), interval_min=0.01, keep=50)  # every 0.6 s
    db = settings.paths.db
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        r = c.post("/api/v1/backups")
        assert r.status_code == 201, r.text
        made = r.json()
        assert made["reason"] == "manual" and made["counts"]["participants"] == 0
        assert (db.parent / "backups" / made["name"]).is_file()
        c.post("/api/v1/participants", json={"code": "P07"})
        wait_until(lambda: "auto" in _reasons(settings), "a timed backup of the change")
        auto = list_backups(db.parent / "backups", db)[0]
        assert _codes(auto.path) == ["P07"]
        time.sleep(3.0)  # five intervals without a change
        assert _reasons(settings).count("auto") == 1


def test_a_backup_that_cannot_be_written_is_a_503_and_shown_and_the_server_goes_on(tmp_path: Path) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("a file where the backup folder should be")
    settings = _with_backups(make_settings(tmp_path), folder=blocker)
    with TestClient(create_app(settings, pipeline_factory=None)) as c:
        r = c.post("/api/v1/backups")
        assert r.status_code == 503 and "cannot create the backup folder" in r.json()["detail"]
        status = c.get("/api/v1/backups").json()
        assert status["last"] is None and "cannot create the backup folder" in status["last_error"]
        assert c.post("/api/v1/participants", json={"code": "P01"}).status_code == 201
    assert blocker.read_text() == "a file where the backup folder should be"
    con = sqlite3.connect(settings.paths.db)
    failed = [r[0] for r in con.execute("SELECT payload FROM events WHERE kind = 'backup'")]
    con.close()
    assert any('"failed"' in p and '"manual"' in p for p in failed) and any('"stop"' in p for p in failed)
    assert _codes(settings.paths.db) == ["P01"]


def test_no_migration_without_its_backup(tmp_path: Path) -> None:
    blocker = tmp_path / "not-a-folder"
    blocker.write_text("x")
    settings = _with_backups(make_settings(tmp_path), folder=blocker)
    engine = make_engine(settings.paths.db)
    upgrade(engine, "0001_initial")
    engine.dispose()
    before = _sha(settings.paths.db)
    app = create_app(settings, pipeline_factory=None)
    with pytest.raises(ConfigError, match="needs a migration and could not be backed up"), TestClient(app):
        pass
    assert _sha(settings.paths.db) == before and inspect_database(settings.paths.db)[0] == "0001_initial"


def test_the_backups_say_whether_they_share_the_database_s_disk(tmp_path: Path) -> None:
    """Beside the database (the default) they do; on another file system (here the RAM disk
    /dev/shm, when it is one) they do not; a folder not made yet is judged by its parent."""
    from app.services.backup import same_disk

    with TestClient(create_app(make_settings(tmp_path), pipeline_factory=None)) as c:
        assert c.get("/api/v1/backups").json()["same_disk"] is True
    assert same_disk(tmp_path / "not" / "made" / "yet", tmp_path) is True
    shm = Path("/dev/shm")
    if not shm.is_dir() or shm.stat().st_dev == tmp_path.stat().st_dev:
        pytest.skip("no second file system at /dev/shm")
    folder = shm / f"cavewalk-test-{tmp_path.name}"
    settings = _with_backups(make_settings(tmp_path), folder=folder)
    try:
        with TestClient(create_app(settings, pipeline_factory=None)) as c:
            assert c.get("/api/v1/backups").json()["same_disk"] is False
    finally:
        import shutil

        shutil.rmtree(folder, ignore_errors=True)


@pytest.mark.parametrize(
    "command",
    [
        ["models", "list"],  # the model registry's commands (models, train, evaluate --db)
        ["study", "report", "--out", "{tmp}/report"],
    ],
    ids=["models list", "study report"],
)
def test_a_command_that_migrates_an_older_database_backs_it_up_first(
    command: list[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Not only the server: every command that migrates a database makes the ``before-upgrade`` copy
    at the old revision first (``cavewalk serve``: tests/app/test_serve_cli.py)."""
    db = older_database(tmp_path / "study.db")
    args = [a.replace("{tmp}", str(tmp_path)) for a in command]
    assert run_cli([*args, "--db", str(db)], monkeypatch) == 0
    (before,) = list_backups(tmp_path / "backups", db)
    assert before.reason == "before-upgrade" and inspect_database(before.path)[0] == "0001_initial"
    con = sqlite3.connect(before.path)
    assert con.execute("SELECT code FROM participants").fetchall() == [("P01",)]
    con.close()
    assert inspect_database(db)[0] == head_revision(), "then migrated"
    assert run_cli([*args, "--db", str(db)], monkeypatch) == 0
    assert len(list_backups(tmp_path / "backups", db)) == 1, "no copy when no migration is due"
