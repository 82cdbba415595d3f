"""Backups of the study database: consistent copies taken while the server writes, and a restore.

A copy is made with SQLite's online backup API from a read-only connection, in one step: in WAL
mode that is one read transaction, so the copy holds every transaction committed before it began
and none after, and the server's writes go on meanwhile. The copy is written to a ``.part`` file,
checked (``PRAGMA quick_check`` and the Alembic revision), synced to disk and only then renamed
into place, so a folder of backups never holds a half-written one.

Backups live in one folder (default ``backups/`` beside the database), named
``<database stem>-<UTC YYYYmmdd-HHMMSS>-<reason>.db``; :func:`prune_backups` keeps the newest of a
database's backups and never touches another file. :func:`restore_database` puts a backup in
place of the database; it first takes the database's lock (no server may be using it) and backs
up the database it replaces.
"""

from __future__ import annotations

import contextlib
import logging
import os
import re
import shutil
import sqlite3
from collections.abc import Iterator
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from app.db.engine import DatabaseLock, connect_read_only, table_names
from app.db.migrate import head_revision, known_revisions
from pipeline.errors import InputError

log = logging.getLogger(__name__)

#: Why a backup was made (the last part of its file name).
REASONS = ("manual", "start", "before-upgrade", "session-end", "auto", "stop", "before-restore")
#: The tables whose rows a backup's summary counts.
COUNTED = ("participants", "study_sessions", "questionnaire_responses", "events", "takes")
_NAME = re.compile(r"^(?P<stem>.+)-(?P<stamp>\d{8}-\d{6})(?:-(?P<n>\d+))?-(?P<reason>[a-z-]+)\.db$")


class BackupError(InputError):
    """A database or backup cannot be copied, checked or restored (the message says why)."""


@dataclass(frozen=True, slots=True)
class BackupInfo:
    """One backup file: where, when (UTC), why, its size, its Alembic revision and its row counts."""

    path: Path
    created: datetime
    reason: str
    size_bytes: int
    revision: str | None
    counts: dict[str, int]

    def to_json(self) -> dict[str, object]:
        return {
            "path": str(self.path),
            "name": self.path.name,
            "created": self.created.isoformat(),
            "reason": self.reason,
            "size_bytes": self.size_bytes,
            "revision": self.revision,
            "counts": dict(self.counts),
        }


def backup_folder(db_path: Path, configured: Path | None = None) -> Path:
    """The folder of ``db_path``'s backups: ``configured``, else ``backups/`` beside the database."""
    return configured.expanduser() if configured is not None else db_path.parent / "backups"


def _connect_ro(path: Path) -> sqlite3.Connection:
    """A read-only connection (it never switches the file's journal, never creates it)."""
    if not path.is_file():
        raise BackupError(f"database not found: {path}")
    try:
        return connect_read_only(path)
    except sqlite3.Error as exc:
        raise BackupError(f"cannot open {path}: {exc}") from exc


def _summary(con: sqlite3.Connection, path: Path) -> tuple[str | None, dict[str, int]]:
    """(Alembic revision, row counts) of a cavewalk database; BackupError when it is not one or is
    damaged (``PRAGMA quick_check``: every page and row, not whether the indexes match the rows; a
    tenth of ``integrity_check``'s time)."""
    try:
        check = [r[0] for r in con.execute("PRAGMA quick_check").fetchall()]
        if check != ["ok"]:
            raise BackupError(f"{path} is damaged (integrity check: {'; '.join(map(str, check[:3]))})")
        tables = table_names(con)
        if "alembic_version" not in tables or "participants" not in tables:
            raise BackupError(f"{path} is not a cavewalk database (no participants table or revision)")
        row = con.execute("SELECT version_num FROM alembic_version").fetchone()
        counts = {
            t: int(con.execute(f'SELECT count(*) FROM "{t}"').fetchone()[0]) for t in COUNTED if t in tables
        }
    except sqlite3.DatabaseError as exc:
        raise BackupError(f"{path} is not a readable SQLite database: {exc}") from exc
    return (str(row[0]) if row else None), counts


def content_fingerprint(path: Path) -> tuple[str | None, tuple[tuple[str, int, int], ...]]:
    """(Alembic revision, (table, rows, newest rowid) per table) of ``path``, read only and
    unchecked: cheap enough for every start. Equal for a database and a backup that hold the same
    rows; a change that only updated rows in place, adding none, is not seen (the app's changes to
    study records add audit rows, and its other changes add events)."""
    con = _connect_ro(path)
    try:
        tables = sorted(table_names(con))
        if "alembic_version" not in tables:
            raise BackupError(f"{path} is not a cavewalk database (no revision)")
        row = con.execute("SELECT version_num FROM alembic_version").fetchone()
        rows = []
        for t in tables:
            if t.startswith("sqlite_"):
                continue
            n, newest = con.execute(f'SELECT count(*), coalesce(max(rowid), 0) FROM "{t}"').fetchone()
            rows.append((t, int(n), int(newest)))
    except sqlite3.DatabaseError as exc:
        raise BackupError(f"{path} is not a readable SQLite database: {exc}") from exc
    finally:
        con.close()
    return (str(row[0]) if row else None), tuple(rows)


def inspect_database(path: Path) -> tuple[str | None, dict[str, int]]:
    """(Alembic revision, row counts) of the database or backup ``path``, read only and checked."""
    con = _connect_ro(path)
    try:
        return _summary(con, path)
    finally:
        con.close()


def _fsync_dir(folder: Path) -> None:
    with contextlib.suppress(OSError):  # not every file system lets a folder be opened
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _copy(src: sqlite3.Connection, out: Path) -> None:
    """``src`` into the new file ``out`` in one backup step, synced to disk."""
    dst = sqlite3.connect(out)
    try:
        src.backup(dst)  # pages=-1: all at once, in one read transaction of the source
        dst.execute("PRAGMA journal_mode=DELETE")  # a backup is one self-contained file
    finally:
        dst.close()
    with out.open("rb+") as f:
        os.fsync(f.fileno())


def new_backup_path(folder: Path, db_path: Path, reason: str, now: datetime | None = None) -> Path:
    """A file name in ``folder`` for a backup of ``db_path`` made now, not taken yet (a second
    backup within the same second is numbered after the first, whatever its reason)."""
    if reason not in REASONS:
        raise ValueError(f"reason must be one of {REASONS}, got {reason!r}")
    stamp = (now or datetime.now(UTC)).strftime("%Y%m%d-%H%M%S")
    taken = [
        m
        for p in (folder.glob(f"{db_path.stem}-{stamp}-*") if folder.is_dir() else ())
        if (m := _NAME.match(p.name.removesuffix(".part"))) and m["stem"] == db_path.stem
    ]
    if not taken:
        return folder / f"{db_path.stem}-{stamp}-{reason}.db"
    n = 1 + max(int(m["n"] or 0) for m in taken)
    return folder / f"{db_path.stem}-{stamp}-{n}-{reason}.db"


def backup_database(db_path: Path, out: Path) -> BackupInfo:
    """Copy the database ``db_path`` (in use or not) to the new file ``out``, checked; its info.

    BackupError when the database is missing, damaged or not a cavewalk database, when ``out``
    exists, or when the copy cannot be written (nothing is left at ``out`` then)."""
    if out.exists():
        raise BackupError(f"{out} already exists: a backup never overwrites a file")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BackupError(f"cannot create the backup folder {out.parent}: {exc.strerror or exc}") from exc
    part = out.with_name(out.name + ".part")
    src = _connect_ro(db_path)
    try:
        try:
            _summary(src, db_path)  # a damaged or foreign file is refused before anything is written
            part.unlink(missing_ok=True)
            _copy(src, part)
        except sqlite3.Error as exc:
            raise BackupError(f"cannot back up {db_path} to {out}: {exc}") from exc
        except OSError as exc:
            raise BackupError(f"cannot write the backup {out}: {exc.strerror or exc}") from exc
        revision, counts = inspect_database(part)  # the copy itself is checked, not the source
        if out.exists():
            raise BackupError(f"{out} already exists: a backup never overwrites a file")
        part.rename(out)
        _fsync_dir(out.parent)
    except BaseException:
        part.unlink(missing_ok=True)
        raise
    finally:
        src.close()
    match = _NAME.match(out.name)
    reason = match["reason"] if match and match["reason"] in REASONS else "manual"
    return BackupInfo(out, datetime.now(UTC), reason, out.stat().st_size, revision, counts)


def list_backups(folder: Path, db_path: Path) -> list[BackupInfo]:
    """``db_path``'s backups in ``folder``, newest first (by the time in the name; no file is opened:
    revision None and no counts)."""
    if not folder.is_dir():
        return []
    found = []
    for p in folder.iterdir():
        m = _NAME.match(p.name)
        if not (m and m["stem"] == db_path.stem and m["reason"] in REASONS and p.is_file()):
            continue
        created = datetime.strptime(m["stamp"], "%Y%m%d-%H%M%S").replace(tzinfo=UTC)
        found.append(
            (created, int(m["n"] or 0), BackupInfo(p, created, m["reason"], p.stat().st_size, None, {}))
        )
    found.sort(key=lambda x: (x[0], x[1]), reverse=True)
    return [b for *_, b in found]


def prune_backups(folder: Path, db_path: Path, keep: int) -> list[Path]:
    """Remove all but the newest ``keep`` backups of ``db_path`` in ``folder``; the removed files."""
    if keep < 1:
        raise ValueError(f"keep must be >= 1, got {keep}")
    gone = []
    for b in list_backups(folder, db_path)[keep:]:
        with contextlib.suppress(FileNotFoundError):
            b.path.unlink()
            gone.append(b.path)
        b.path.with_name(b.path.name + "-wal").unlink(missing_ok=True)  # a raw before-restore copy's
    return gone


@contextlib.contextmanager
def _exclusive_db(db_path: Path) -> Iterator[None]:
    lock = DatabaseLock.acquire(db_path)  # DatabaseInUse (naming the server's PID) while one runs
    try:
        yield
    finally:
        lock.release()


def _safety_copy(db_path: Path, folder: Path) -> BackupInfo | None:
    """The database a restore replaces, kept in ``folder`` (``before-restore``): a checked backup,
    or, when the database cannot be read (the damage a restore repairs), its files as they are."""
    if not db_path.is_file() or db_path.stat().st_size == 0:
        return None
    out = new_backup_path(folder, db_path, "before-restore")
    try:
        return backup_database(db_path, out)
    except BackupError as exc:
        if out.exists() or not db_path.is_file():
            raise
        reason = exc
    try:
        shutil.copyfile(db_path, out)  # byte for byte, and its WAL beside it: nothing is lost
        wal = db_path.with_name(db_path.name + "-wal")
        if wal.is_file():
            shutil.copyfile(wal, out.with_name(out.name + "-wal"))
    except OSError as exc:
        out.unlink(missing_ok=True)
        raise BackupError(
            f"cannot keep the database {db_path} before the restore: {exc.strerror or exc}"
        ) from exc
    log.warning("the database could not be read (%s): its files are kept as they are in %s", reason, out)
    return BackupInfo(out, datetime.now(UTC), "before-restore", out.stat().st_size, None, {})


def restore_database(backup: Path, db_path: Path, folder: Path) -> tuple[BackupInfo | None, BackupInfo]:
    """Put the backup ``backup`` in place of the database ``db_path``.

    The backup is checked first (a damaged, foreign or newer-than-this-cavewalk file is refused and
    nothing changes). No server may be using the database (its lock is taken). The database it
    replaces is kept in ``folder`` first (reason ``before-restore``: a checked backup, or its files
    as they are when it cannot be read; None when there was no database). The backup is copied
    beside the database, checked, and renamed over it (the old WAL and shared-memory files go).
    Returns (that safety copy, the restored database's info)."""
    revision, _counts = inspect_database(backup)
    if revision not in known_revisions():
        raise BackupError(
            f"{backup} has the database revision {revision}, which this cavewalk does not know "
            f"(its newest is {head_revision()}): a newer cavewalk made it"
        )
    if db_path.is_dir():
        raise BackupError(f"database {db_path} is a folder, not a file")
    with _exclusive_db(db_path):
        safety = _safety_copy(db_path, folder)
        part = db_path.with_name(db_path.name + ".restoring")
        try:
            shutil.copyfile(backup, part)
            with part.open("rb+") as f:
                os.fsync(f.fileno())
            revision, counts = inspect_database(part)  # what goes in place, checked once
            for suffix in ("-wal", "-shm"):  # the replaced database's (kept in the safety copy)
                db_path.with_name(db_path.name + suffix).unlink(missing_ok=True)
            part.replace(db_path)
            _fsync_dir(db_path.parent)
        except OSError as exc:
            raise BackupError(f"cannot restore {backup} into {db_path}: {exc.strerror or exc}") from exc
        finally:
            part.unlink(missing_ok=True)
    return safety, BackupInfo(
        db_path, datetime.now(UTC), "restored", db_path.stat().st_size, revision, counts
    )
