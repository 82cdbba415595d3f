"""The SQLite engine: WAL journal, foreign keys on, one file per installation; and the lock
that keeps a second server off a database one server is using.

Every commit is synced to disk (``synchronous=FULL``): with ``NORMAL`` a WAL database stays
intact after a power cut but may lose the transactions committed since its last checkpoint (a
participant's questionnaire, answered and thanked for). The cost here is about half a millisecond
per commit, and the server commits a few times a second (the event log's batches, the API's writes).

:class:`DatabaseLock` takes an exclusive ``flock`` on ``<db>.lock`` beside the database and
writes the holder's PID into it. Two servers on one database both attached to the running
session and wrote events into it (issue 15 D5); now the second one ends with a message that
names the PID holding the lock. The lock goes with the process (even on kill -9), so a stale
lock file is harmless; it is never deleted (deleting lock files races with the next taker).
Commands that only read the database (``study report``) take no lock.
"""

from __future__ import annotations

import os
import sqlite3
import threading
from pathlib import Path
from typing import Any, ClassVar

from sqlalchemy import Engine, create_engine, event
from sqlalchemy.orm import Session, sessionmaker

from pipeline.errors import ConfigError

try:
    import fcntl
except ImportError:  # not on POSIX: no lock
    fcntl = None  # type: ignore[assignment]


class DatabaseInUse(ConfigError):
    """Another process holds the database's lock."""


def lock_path(db_path: Path) -> Path:
    return db_path.with_name(db_path.name + ".lock")


class DatabaseLock:
    """An exclusive lock on a database for this process (re-entrant within it)."""

    _held: ClassVar[dict[Path, tuple[DatabaseLock, int]]] = {}
    _guard: ClassVar[threading.Lock] = threading.Lock()

    def __init__(self, db_path: Path, fd: int | None) -> None:
        self.db_path = db_path
        self._fd = fd

    @classmethod
    def acquire(cls, db_path: Path) -> DatabaseLock:
        """Take the lock of ``db_path`` (its folder is created); :class:`DatabaseInUse` naming the
        holder's PID when another process has it, ConfigError when the lock file cannot be made."""
        key = Path(os.path.abspath(db_path.expanduser()))
        with cls._guard:
            held = cls._held.get(key)
            if held is not None:
                cls._held[key] = (held[0], held[1] + 1)
                return held[0]
            lock = cls(key, cls._take(key))
            cls._held[key] = (lock, 1)
            return lock

    @staticmethod
    def _take(db_path: Path) -> int | None:
        if fcntl is None:
            return None
        path = lock_path(db_path)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise ConfigError(f"cannot create the database lock {path}: {exc.strerror or exc}") from exc
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            try:
                holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            finally:
                os.close(fd)
            raise DatabaseInUse(
                f"database {db_path} is in use by another cavewalk server (PID {holder} holds {path.name}); "
                "stop that server or give this one another --db"
            ) from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        return fd

    def release(self) -> None:
        with self._guard:
            lock, count = self._held.get(self.db_path, (self, 1))
            if count > 1:
                self._held[self.db_path] = (lock, count - 1)
                return
            self._held.pop(self.db_path, None)
            if self._fd is not None:
                os.close(self._fd)  # closing the descriptor releases the flock
                self._fd = None


def _on_connect(dbapi_connection: Any, _record: Any) -> None:
    if isinstance(dbapi_connection, sqlite3.Connection):
        cur = dbapi_connection.cursor()
        cur.execute("PRAGMA journal_mode=WAL")
        cur.execute("PRAGMA foreign_keys=ON")
        cur.execute("PRAGMA synchronous=FULL")  # a power cut loses no committed transaction
        cur.execute("PRAGMA busy_timeout=5000")
        cur.close()


def connect_read_only(path: Path, timeout_s: float = 10.0) -> sqlite3.Connection:
    """A plain sqlite3 connection that only reads ``path``: it never creates the file and never
    switches its journal (the app's engine sets WAL on connect, which writes to the file)."""
    return sqlite3.connect(f"{path.resolve().as_uri()}?mode=ro", uri=True, timeout=timeout_s)


def table_names(con: sqlite3.Connection) -> set[str]:
    """The tables of the database behind ``con`` (sqlite3.DatabaseError when it is not one)."""
    return {str(r[0]) for r in con.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}


def make_engine(db_path: Path) -> Engine:
    """An engine on the SQLite file ``db_path`` (its folder is created)."""
    try:
        db_path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ConfigError(f"cannot create the database folder {db_path.parent}: {exc}") from exc
    engine = create_engine(
        f"sqlite:///{db_path}",
        connect_args={"check_same_thread": False, "timeout": 10},
        pool_pre_ping=False,
    )
    event.listen(engine, "connect", _on_connect)
    return engine


def make_session_factory(engine: Engine) -> sessionmaker[Session]:
    return sessionmaker(bind=engine, expire_on_commit=False)
