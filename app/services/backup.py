"""The server's automatic backups of its database (:mod:`app.db.backup` makes and checks each copy).

- **At start**: when a migration is due, before it (reason ``before-upgrade``; the server does not
  start when that copy cannot be made); otherwise soon after start (``start``, from the backup
  thread), unless the database holds the same rows as its newest backup (the last server stopped
  cleanly; a killed one left rows no backup holds). Every command that migrates a database makes
  the ``before-upgrade`` copy first (:func:`backup_before_upgrade`: ``serve`` and ``demo`` before
  their own migration, the model registry's commands, ``study report``, ``record``); a newer
  cavewalk's database is not copied (nothing here migrates it).
- **When a study session ends** (its run time is over or the operator stopped it), with the
  session's events flushed first (``session-end``).
- **Every** ``interval_min`` while the data changes (``auto``), and **at stop** when it changed
  since the last backup (``stop``).
- **By hand**: the dashboard's *Back up now* and ``POST /api/v1/backups`` (``manual``).

Each backup is followed by pruning to the newest ``keep``. A backup that fails (a full disk, a
folder that cannot be written) is logged, recorded as a ``backup`` event and shown on the
dashboard; the server goes on.
"""

from __future__ import annotations

import logging
import threading
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from app.core.config import BackupSettings
from app.db.backup import (
    BackupError,
    BackupInfo,
    backup_database,
    backup_folder,
    content_fingerprint,
    list_backups,
    new_backup_path,
    prune_backups,
)
from app.db.errors import StateConflict
from app.db.migrate import head_revision, known_revisions
from app.services.event_log import EventWriter
from app.services.storage import StorageWatch, existing_folder
from pipeline.errors import ConfigError

log = logging.getLogger(__name__)


def backup_before_upgrade(db_path: Path, settings: BackupSettings) -> BackupInfo | None:
    """What a command that migrates a database does first: the ``before-upgrade`` backup when a
    migration is due (:meth:`BackupService.before_upgrade`; ConfigError when the copy cannot be made,
    and nothing may be migrated then)."""
    return BackupService(db_path, settings).before_upgrade()


def _migration_due(revision: str | None) -> bool:
    """A database at ``revision`` is an older cavewalk's (None: an empty revision table): this code
    migrates it. Another unknown revision is a newer cavewalk's, which nothing here migrates (the
    migration refuses it, and nothing is copied for it)."""
    return revision != head_revision() and (revision is None or revision in known_revisions())


def _signature(db_path: Path) -> tuple[int, ...]:
    """Changes with every commit: the sizes and modification times of the database and its WAL."""
    sig: list[int] = []
    for p in (db_path, db_path.with_name(db_path.name + "-wal")):
        try:
            st = p.stat()
            sig += [st.st_size, st.st_mtime_ns]
        except FileNotFoundError:
            sig += [-1, -1]
    return tuple(sig)


class BackupService:
    """Backs up ``db_path`` as :mod:`app.services.backup` says; thread-safe."""

    def __init__(self, db_path: Path, settings: BackupSettings) -> None:
        self.db_path = db_path
        self.settings = settings
        self.folder = backup_folder(db_path, settings.folder)
        self._events: EventWriter | None = None
        self._storage: StorageWatch | None = None
        self._lock = threading.Lock()  # one backup at a time
        self._wake = threading.Condition()
        self._pending: list[str] = []
        self._closing = False
        self._thread: threading.Thread | None = None
        self._session: int | None = None
        self._backed_sig: tuple[int, ...] | None = None
        self.last: BackupInfo | None = None
        self.last_error: str | None = None

    # -- at start, before the migrations -----------------------------------------------------
    def before_upgrade(self) -> BackupInfo | None:
        """The ``before-upgrade`` backup when a migration is due (returned; ConfigError when it cannot
        be made: the caller migrates nothing then). None when backups are off, the file is new or
        empty, already at this code's revision, or no cavewalk database (the migration says so)."""
        fingerprint = self._fingerprint(quiet=True)
        if fingerprint is None or not _migration_due(fingerprint[0]):
            return None
        return self._upgrade_backup()

    def before_start(self) -> BackupInfo | None:
        """Before the migrations: the ``before-upgrade`` backup when one is due (returned;
        ConfigError when it cannot be made). Otherwise a ``start`` backup is queued for the backup
        thread, unless the database holds the same rows as its newest backup (cheap: row counts and
        the newest row of each table, :func:`~app.db.backup.content_fingerprint`)."""
        fingerprint = self._fingerprint(quiet=False)
        if fingerprint is None:
            return None
        revision, now = fingerprint
        if _migration_due(revision):
            return self._upgrade_backup()
        newest = list_backups(self.folder, self.db_path)
        if newest:
            try:
                same = content_fingerprint(newest[0].path) == (revision, now)
            except BackupError:
                same = False
            if same:  # the last server stopped cleanly (its stop backup holds everything)
                self.last = newest[0]
                return None
        self.request("start")  # the last server left rows no backup holds: the thread's first copy
        return None

    # -- while the server runs ---------------------------------------------------------------
    def attach(self, events: EventWriter) -> None:
        """Log into ``events`` (each backup's copy holds the events up to it) and back up when a
        study session ends."""
        self._events = events
        self._session = events.session_id
        events.on_session_change(self.session_changed)

    def refuse_when(self, storage: StorageWatch) -> None:
        """No backup while ``storage`` says the disk is full (a copy would take the last space)."""
        self._storage = storage

    def start(self) -> None:
        if self.settings.enabled and self._thread is None:
            if self._backed_sig is None:
                self._backed_sig = _signature(self.db_path)  # the timer backs up what changes from now
            self._thread = threading.Thread(target=self._run, name="cavewalk-backup", daemon=True)
            self._thread.start()

    def session_changed(self) -> None:
        """Called after each change of the running study session: its end asks for a backup."""
        now = self._events.session_id if self._events is not None else None
        ended = self._session is not None and now is None
        self._session = now
        if ended:
            self.request("session-end")

    def request(self, reason: str) -> None:
        """A backup soon, from the backup thread (no-op when backups are off)."""
        if not self.settings.enabled:
            return
        with self._wake:
            self._pending.append(reason)
            self._wake.notify()

    def backup_now(self, reason: str = "manual") -> BackupInfo:
        """A backup now (the events queued so far included); BackupError when it fails."""
        return self._backup(reason)

    def close(self) -> None:
        """Stop the thread; a last backup when the data changed since the last one (call it after
        the event log is closed, so its last events are in)."""
        with self._wake:
            self._closing = True
            self._wake.notify()
        if self._thread is not None:
            self._thread.join(timeout=60)
            self._thread = None
            if _signature(self.db_path) != self._backed_sig:
                self._try("stop")

    def status(self) -> dict[str, Any]:
        """What the dashboard shows: the settings, the newest backups, the last one and its error."""
        return {
            "enabled": self.settings.enabled,
            "folder": str(self.folder),
            "keep": self.settings.keep,
            "interval_min": self.settings.interval_min,
            "last": self.last.to_json() if self.last else None,
            "last_error": self.last_error,
            "same_disk": same_disk(self.folder, self.db_path.parent),
            "backups": [b.to_json() for b in list_backups(self.folder, self.db_path)],
        }

    # -- the work ----------------------------------------------------------------------------
    def _run(self) -> None:
        interval = self.settings.interval_min * 60.0
        while True:
            with self._wake:
                if not self._pending and not self._closing:
                    self._wake.wait(timeout=interval if interval > 0 else None)
                if self._closing:
                    return
                reasons, self._pending = self._pending, []
            if reasons:
                self._try(reasons[0])
            elif interval > 0 and _signature(self.db_path) != self._backed_sig:
                self._try("auto")

    def _try(self, reason: str) -> BackupInfo | None:
        try:
            return self._backup(reason)
        except BackupError:
            return None  # logged, recorded and shown by _backup

    def _fingerprint(self, quiet: bool) -> tuple[str | None, tuple[tuple[str, int, int], ...]] | None:
        """The database's :func:`~app.db.backup.content_fingerprint`; None when backups are off, the
        file is new or empty, or it cannot be read as a cavewalk database (logged unless ``quiet``)."""
        if not self.settings.enabled or not self.db_path.is_file() or self.db_path.stat().st_size == 0:
            return None
        try:
            return content_fingerprint(self.db_path)
        except BackupError as exc:  # not a cavewalk database, or damaged: the migration says so
            if not quiet:
                log.warning("no start backup: %s", exc)
            return None

    def _upgrade_backup(self) -> BackupInfo:
        try:
            return self._backup("before-upgrade")
        except BackupError as exc:
            raise ConfigError(
                f"the database needs a migration and could not be backed up first: {exc}; "
                "free the backup folder (backup.folder) or back it up by hand"
            ) from exc

    def _backup(self, reason: str) -> BackupInfo:
        with self._lock:
            if self._events is not None:  # the copy holds every event up to its own
                self._events.record("backup", {"state": "started", "reason": reason})
                self._events.flush()
            sig = _signature(self.db_path)
            try:
                if self._storage is not None:
                    try:
                        self._storage.require("a backup")
                    except StateConflict as exc:
                        raise BackupError(str(exc)) from exc
                info = backup_database(self.db_path, new_backup_path(self.folder, self.db_path, reason))
            except BackupError as exc:
                self.last_error = f"{datetime.now(UTC).isoformat(timespec='seconds')}: {exc}"
                log.error("backup (%s) failed: %s", reason, exc)
                if self._events is not None:
                    self._events.record("backup", {"state": "failed", "reason": reason, "message": str(exc)})
                raise
            self._backed_sig = sig
            self.last, self.last_error = info, None
            removed = prune_backups(self.folder, self.db_path, self.settings.keep)
            log.info(
                "database backed up (%s): %s, %d bytes%s",
                reason,
                info.path,
                info.size_bytes,
                f"; {len(removed)} older removed" if removed else "",
            )
            return info


def same_disk(folder: Path, other: Path) -> bool | None:
    """True when ``folder`` (or, before it exists, its nearest existing parent) is on the same file
    system as ``other``: a backup there does not survive that disk. None when either cannot be read."""
    try:
        return existing_folder(folder).stat().st_dev == other.stat().st_dev
    except OSError:
        return None
