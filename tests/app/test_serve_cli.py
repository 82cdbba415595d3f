"""`cavewalk serve` / `demo`: bad options end with one clear message (exit 2), never a traceback."""

from __future__ import annotations

import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from pipeline.errors import CavewalkError
from tests.app.conftest import older_database
from tests.datagrams import DatagramRecorder
from tests.waiting import free_port, wait_until

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def busy_port() -> Iterator[int]:
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen()
    yield int(s.getsockname()[1])
    s.close()


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["--emit", "nohostport"], "--emit"),
        (["--emit", "ws1:99999"], "port must be 1-65535"),
        (["--port", "busy"], "is in use"),
        (["--viser-port", "busy"], "is in use"),
        (["--db", "FOLDER"], "is a folder"),
        (["--config", "missing.toml"], "config file not found"),
        (["--db", "NOTADB"], "cannot be used: file is not a database"),
        (["--navigation", "crowd"], "--navigation: navigation mode must be one of single, each, group"),
        ([], "stream-seq does not hold a seq number"),  # a seq file beside the database holding no number
    ],
)
def test_bad_options_raise_a_cavewalk_error(
    args: list[str], match: str, busy_port: int, tmp_path: Path
) -> None:
    args = [str(busy_port) if a == "busy" else str(tmp_path) if a == "FOLDER" else a for a in args]
    args = [str(tmp_path / a) if a.endswith(".toml") else a for a in args]
    if "NOTADB" in args:
        notes = tmp_path / "notes.txt"
        notes.write_text("these are my notes, not a database\n" * 100)
        args[args.index("NOTADB")] = str(notes)
    bad_seq_file = not args
    if bad_seq_file:
        (tmp_path / "stream-seq").write_text("my notes\n")
    if "--db" not in args:
        args += ["--db", str(tmp_path / "x.db")]
    for opt in ("--port", "--viser-port"):  # not 8000/8080, which another server here may hold
        if opt not in args:
            args += [opt, str(free_port())]
    result = CliRunner().invoke(cli, ["demo", *args])
    assert isinstance(result.exception, CavewalkError), result.output
    assert match in str(result.exception)
    assert not (tmp_path / "x.db").exists(), "a refused start creates no database"
    if bad_seq_file:
        assert (tmp_path / "stream-seq").read_text() == "my notes\n", "left unchanged"
    if (tmp_path / "notes.txt").exists():
        assert (tmp_path / "notes.txt").read_text().startswith("these are my notes"), "left unchanged"


@pytest.mark.slow
def test_main_prints_one_line_and_exits_2(busy_port: int, tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "app.cli", "serve", "--port", str(busy_port), "--db", str(tmp_path / "a.db")],
        cwd=ROOT, capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert proc.returncode == 2
    assert (
        proc.stderr.strip().splitlines()[-1]
        == f"error: port {busy_port} on 127.0.0.1 is in use (choose another with --port)"
    )
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_a_second_server_on_one_database_stops_naming_the_first(tmp_path: Path) -> None:
    """Two real `cavewalk serve` on one --db (issue 15 D5): the second ends with one message
    naming the PID of the first; once the first is gone (even by kill -9) the database is free."""
    db = tmp_path / "study.db"

    def serve() -> subprocess.Popen[str]:
        cmd = [sys.executable, "-m", "app.cli", "serve", "--db", str(db), "--port", str(free_port()),
               "--viser-port", str(free_port())]
        return subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    first = serve()
    try:
        assert first.stdout is not None
        # generous: start-up imports the pipeline; it only waits for the line, it races nothing
        line = ""
        for line in first.stdout:
            if line.startswith("database:"):
                break
        assert line.startswith("database:"), f"the first server did not start: {first.stderr}"
        second = serve()
        out, err = second.communicate(timeout=120)
        assert second.returncode == 2, (out, err)
        last = err.strip().splitlines()[-1]
        assert last.startswith("error: database ") and f"PID {first.pid}" in last, err
        assert "Traceback" not in err and "cavewalk dashboard" not in out, "it never started serving"
        assert first.poll() is None, "the first server runs on"
    finally:
        first.kill()  # kill -9: the lock goes with the process
        first.wait(timeout=30)
    third = serve()
    try:
        assert third.stdout is not None
        started = any(line.startswith("database:") for line in third.stdout)
        assert started, "a free database serves again"
    finally:
        third.kill()
        third.wait(timeout=30)


def _bad_database(tmp_path: Path, kind: str) -> Path:
    """A database file that cannot serve: another program's, a newer cavewalk's, cut short."""
    import shutil
    import sqlite3

    from app.db.migrate import prepare_database

    db = tmp_path / f"{kind}.db"
    if kind == "foreign":
        con = sqlite3.connect(db)
        con.execute("create table participants (x)")
        con.execute("insert into participants values (1)")
        con.commit()
        con.close()
        return db
    good = tmp_path / "good.db"
    prepare_database(good)
    if kind == "future":
        shutil.copy(good, db)
        con = sqlite3.connect(db)
        con.execute("update alembic_version set version_num = '0099_from_the_future'")
        con.commit()
        con.close()
    elif kind == "truncated":
        data = good.read_bytes()
        db.write_bytes(data[: len(data) // 3])
    return db


@pytest.mark.parametrize(
    ("kind", "match"),
    [
        ("foreign", "is not a cavewalk database (it has the tables participants"),
        ("future", "cannot be migrated"),
        ("truncated", "malformed"),
    ],
)
def test_a_database_that_cannot_serve_is_one_message_and_left_unchanged(
    kind: str, match: str, tmp_path: Path
) -> None:
    db = _bad_database(tmp_path, kind)
    before = db.read_bytes()
    result = CliRunner().invoke(cli, ["serve", "--db", str(db), "--port", str(free_port()),
                                      "--viser-port", str(free_port())])
    assert isinstance(result.exception, CavewalkError), result.output
    assert match in str(result.exception) and str(db) in str(result.exception)
    assert db.read_bytes() == before, "a refused database is not touched"
    assert not (tmp_path / "backups").exists(), "nor copied: a newer cavewalk's database is no upgrade"
    # the log file (beside the database) says why the server did not start, as the terminal did
    logged = (tmp_path / "logs" / "cavewalk.log").read_text(encoding="utf-8")
    assert "ERROR" in logged and "the server did not start" in logged and match in logged, logged


@pytest.mark.slow
def test_serve_backs_up_an_older_database_before_it_migrates_it_and_logs_both(tmp_path: Path) -> None:
    """`cavewalk serve` on an older cavewalk's database: a ``before-upgrade`` copy at the old revision,
    holding its rows, is made before the migration, and the log file has both lines in that order
    (the command used to migrate before the app's own start backup could run, so no copy of the old
    database was made, and its migration line was not in the log file)."""
    import sqlite3

    from app.db.backup import inspect_database, list_backups
    from app.db.migrate import head_revision

    db = older_database(tmp_path / "study.db")
    port = free_port()
    cmd = [sys.executable, "-m", "app.cli", "serve", "--db", str(db), "--port", str(port),
           "--viser-port", str(free_port())]
    server = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        def answers() -> bool:
            with socket.socket() as s:
                return s.connect_ex(("127.0.0.1", port)) == 0

        wait_until(answers, "the server answering on its port")
    finally:
        server.send_signal(signal.SIGINT)
        _out, err = server.communicate(timeout=60)
    assert server.returncode == 0, err
    backups = {b.reason: b for b in list_backups(tmp_path / "backups", db)}
    before = backups["before-upgrade"]
    assert inspect_database(before.path)[0] == "0001_initial"
    con = sqlite3.connect(before.path)
    assert con.execute("SELECT code FROM participants").fetchall() == [("P01",)]
    con.close()
    assert inspect_database(db)[0] == head_revision()
    lines = (tmp_path / "logs" / "cavewalk.log").read_text(encoding="utf-8").splitlines()
    copied = next(i for i, x in enumerate(lines) if "database backed up (before-upgrade)" in x)
    migration = f"database migrated from 0001_initial to {head_revision()}"
    migrated = next(i for i, x in enumerate(lines) if migration in x)
    assert copied < migrated, lines[:5]


def test_serve_does_not_migrate_an_older_database_it_cannot_back_up_first(tmp_path: Path) -> None:
    """The backup folder is a file: one message, and the older database is left as it was."""
    from app.db.backup import inspect_database

    db = older_database(tmp_path / "study.db")
    before = db.read_bytes()
    (tmp_path / "not-a-folder").write_text("a file where the backups should go\n")
    cmd = [sys.executable, "-m", "app.cli", "serve", "--db", str(db), "--port", str(free_port()),
           "--viser-port", str(free_port())]
    env = {**os.environ, "CAVEWALK_BACKUP__FOLDER": str(tmp_path / "not-a-folder")}
    server = subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        _out, err = server.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # it started: it migrated without a copy
        server.send_signal(signal.SIGINT)
        server.communicate(timeout=60)
        pytest.fail("the server started on a database it could not back up before its migration")
    assert server.returncode == 2 and "Traceback" not in err, err
    last = err.strip().splitlines()[-1]
    assert last.startswith("error: the database needs a migration and could not be backed up first"), err
    assert db.read_bytes() == before and inspect_database(db)[0] == "0001_initial", "not migrated"


@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() != 0 or shutil.which("setpriv") is None,
                    reason="root ignores file modes: drops to nobody with setpriv")
@pytest.mark.parametrize("where", ["file", "folder"])
def test_a_read_only_database_is_one_message(where: str) -> None:
    """As nobody (root writes anything): a database file, or its folder, the user cannot write."""
    import tempfile

    from app.db.migrate import prepare_database

    top = Path(tempfile.mkdtemp(prefix="cavewalk-ro-"))  # /tmp: nobody can reach it (pytest's is 0700)
    try:
        folder = top / "ro"
        folder.mkdir()
        db = folder / "study.db"
        prepare_database(db)
        db.chmod(0o444 if where == "file" else 0o644)
        top.chmod(0o755)
        folder.chmod(0o777 if where == "file" else 0o555)
        cmd = [shutil.which("setpriv") or "setpriv", "--reuid=65534", "--regid=65534", "--clear-groups",
               sys.executable, "-m", "app.cli", "serve", "--db", str(db), "--port", str(free_port()),
               "--viser-port", str(free_port())]
        env = {**os.environ, "HOME": str(top), "PYTHONDONTWRITEBYTECODE": "1"}
        proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=120, env=env)
        assert proc.returncode == 2, proc.stderr
        last = proc.stderr.strip().splitlines()[-1]
        assert last.startswith("error:") and str(db) in last and "Traceback" not in proc.stderr, proc.stderr
        assert "readonly" in last or "read-only" in last or "ermission denied" in last, last
        assert "cavewalk dashboard" not in proc.stdout, "it never started serving"
    finally:
        folder.chmod(0o755)
        shutil.rmtree(top)


def _demo(tmp_path: Path, *args: str, **env: str) -> subprocess.Popen[str]:
    cmd = [sys.executable, "-m", "app.cli", "demo", "--db", str(tmp_path / "study.db"), "--port",
           str(free_port()), "--viser-port", str(free_port()), *args]
    return subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, **env})


@pytest.mark.slow
def test_the_server_s_log_file_holds_the_app_s_and_the_workers_records(tmp_path: Path) -> None:
    """`cavewalk demo` writes its log beside the database (logs/cavewalk.log), with the records of
    its worker processes and of its shutdown, as well as to stderr."""
    log = tmp_path / "logs" / "cavewalk.log"
    server = _demo(tmp_path)
    try:
        assert server.stdout is not None
        lines = []
        for line in server.stdout:
            lines.append(line)
            if line.startswith("log file:"):
                break
        assert lines[-1].split(":", 1)[1].strip() == str(log), lines

        def worker_line() -> str | None:  # the simulator's people found by the fusion worker
            text = log.read_text(encoding="utf-8") if log.exists() else ""
            return next((x for x in text.splitlines() if " cavewalk-fuse " in x and "appears" in x), None)

        found = wait_until(worker_line, "a fusion worker's record in the log file")
        assert re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d INFO    cavewalk-fuse ", found), found
    finally:
        server.send_signal(signal.SIGINT)
        _out, err = server.communicate(timeout=60)
    text = log.read_text(encoding="utf-8")
    assert "MainProcess app.services.backup: database backed up (start)" in text
    assert "database backed up (stop)" in text.splitlines()[-1], text.splitlines()[-3:]
    assert "database backed up (stop)" in err, "stderr has it too"


@pytest.mark.slow
def test_no_log_file_when_switched_off_and_a_log_file_that_cannot_be_written_is_one_message(
    tmp_path: Path,
) -> None:
    off = _demo(tmp_path, CAVEWALK_RUNTIME__LOG__ENABLED="false")
    try:
        assert off.stdout is not None
        line = next(x for x in off.stdout if x.startswith("log file:"))
        assert "(none: runtime.log.enabled = false)" in line
    finally:
        off.send_signal(signal.SIGINT)
        off.communicate(timeout=60)
    assert not (tmp_path / "logs").exists()
    (tmp_path / "plain").write_text("a file where a folder should be\n")
    bad = tmp_path / "plain" / "cavewalk.log"
    proc = _demo(tmp_path, CAVEWALK_RUNTIME__LOG__PATH=str(bad))
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 2, err
    assert err.strip().splitlines()[-1] == (f"error: the log file {bad} cannot be written: File exists "
                                           "(set runtime.log.path, or runtime.log.enabled = false)"), err
    assert "Traceback" not in err and "cavewalk dashboard" not in out


@pytest.mark.slow
def test_seq_goes_on_across_server_processes_stopped_and_killed(tmp_path: Path) -> None:
    """Three real `cavewalk demo` processes on one database send to one real UDP workstation: the
    second (after a clean Ctrl+C) goes on with the next seq; the third (after SIGKILL) goes on above
    every seq the killed one sent. A workstation that drops a seq that went back drops nothing."""
    rx = DatagramRecorder()
    seq_file = tmp_path / "stream-seq"
    runs: list[list[int]] = []
    try:
        for end in ("sigint", "sigkill", "sigint"):
            count = len(rx.got)
            server = _demo(tmp_path, "--emit", f"127.0.0.1:{rx.port}")
            try:
                wait_until(lambda: rx.locomotion_since(count) >= 60, "locomotion from the demo")  # noqa: B023
            finally:
                server.send_signal(signal.SIGINT if end == "sigint" else signal.SIGKILL)
                server.communicate(timeout=60)
            time.sleep(0.3)  # what was in flight has arrived
            runs.append([m["seq"] for _, m in rx.got[count:]])
            if end == "sigint":
                assert int(seq_file.read_text()) == runs[-1][-1] + 1, "a clean stop leaves the next seq"
    finally:
        rx.close()
    first, killed, last = runs
    assert first[0] == 0 and first == list(range(len(first))), "the first server starts at 0, no gap"
    assert killed[0] == first[-1] + 1, "after a clean stop: the next seq, no gap"
    assert killed == list(range(killed[0], killed[0] + len(killed)))
    assert killed[-1] < last[0] <= killed[-1] + 100_000, "after a kill: above all it sent, within a lease"
    assert last == list(range(last[0], last[0] + len(last))), "no seq from the killed server's workers"
