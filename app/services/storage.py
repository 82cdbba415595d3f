"""Free disk space where the server writes: the database, its backups and the takes.

A study day fills a disk (a take's camera videos are gigabytes an hour), and a full disk breaks
everything at once: the event log, a participant's questionnaire, the take being recorded, the
backups. :class:`StorageWatch` checks the free space of each file system the server writes to
every ``check_s`` seconds (``shutil.disk_usage``) and sorts the least of them into a level:

- ``ok``;
- ``low`` below ``warn_free_gb``: the dashboard shows the free space in amber;
- ``full`` below ``min_free_gb``: shown in red with a banner; a take being recorded is stopped
  (kept, with what it has), a new take is refused, and so is a backup (a copy that takes the last
  space would leave none for the database itself).

Each change of level goes into the event log (``storage``) and to the dashboard at once.
"""

from __future__ import annotations

import logging
import shutil
import threading
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from app.core.config import StorageSettings
from app.db.errors import StateConflict
from app.services.event_log import EventWriter
from pipeline.errors import CavewalkError

log = logging.getLogger(__name__)

LEVELS = ("ok", "low", "full")
_GB = 1e9


class DiskFull(CavewalkError):
    """A command refused, or stopped, because the disk is ``full`` (the message says how full)."""


def existing_folder(path: Path) -> Path:
    """``path`` or its nearest folder that exists (where its files will go)."""
    path = path.expanduser().absolute()
    while not path.exists() and path != path.parent:
        path = path.parent
    return path


class StorageWatch:
    """Watches the free space of the file systems of ``paths`` (a label per path)."""

    def __init__(
        self,
        paths: Mapping[str, Path],
        settings: StorageSettings,
        events: EventWriter | None = None,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        self.paths = dict(paths)
        self.settings = settings
        self._events = events
        self._on_change = on_change
        self._on_full: tuple[Callable[[str], object], ...] = ()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._state: dict[str, Any] = {
            "level": "ok",
            "free_gb": None,
            "where": None,
            "path": None,
            "message": "",
        }

    def on_full(self, callback: Callable[[str], object]) -> None:
        """``callback(message)`` when the level becomes ``full`` (a take stops)."""
        self._on_full = (*self._on_full, callback)

    def check(self) -> dict[str, Any]:
        """Measure now; the state (also kept for :meth:`current`). A change of level is logged,
        recorded and shown; ``full`` calls the ``on_full`` callbacks."""
        free: dict[int, tuple[int, str, Path]] = {}  # one entry per file system (its first label)
        for label, path in self.paths.items():
            where = existing_folder(path)
            try:
                dev = where.stat().st_dev
                left = shutil.disk_usage(where).free
            except OSError as exc:
                log.warning("free space of %s (%s) unknown: %s", label, where, exc)
                continue
            free.setdefault(dev, (left, label, where))
        if not free:
            return self.current()
        left, label, where = min(free.values(), key=lambda x: x[0])
        gb = left / _GB
        cfg = self.settings
        level = "full" if gb < cfg.min_free_gb else "low" if gb < cfg.warn_free_gb else "ok"
        message = {
            "ok": "",
            "low": f"{gb:.1f} GB free for the {label} ({where}): below storage.warn_free_gb "
            f"({cfg.warn_free_gb:g} GB); free space before the next takes",
            "full": f"the disk is nearly full: {gb:.2f} GB free for the {label} ({where}), below "
            f"storage.min_free_gb ({cfg.min_free_gb:g} GB); takes and backups stop until "
            "space is freed",
        }[level]
        state = {
            "level": level,
            "free_gb": round(gb, 2),
            "where": label,
            "path": str(where),
            "message": message,
        }
        with self._lock:
            before, self._state = self._state["level"], state
        if level != before:
            say = log.info if level == "ok" else log.warning
            say("disk space %s: %s", level, message or f"{gb:.1f} GB free")
            if self._events is not None:
                self._events.record("storage", {"level": level, "free_gb": state["free_gb"], "where": label})
            if level == "full":
                for callback in self._on_full:
                    try:
                        callback(message)
                    except Exception:  # the loop boundary: the other callbacks and the watch go on
                        log.exception("acting on a full disk failed")
            self._on_change()
        return state

    def current(self) -> dict[str, Any]:
        """The newest state: level, free_gb (the least free file system), where, path, message."""
        with self._lock:
            return dict(self._state)

    def require(self, what: str) -> None:
        """StateConflict (409) naming the free space when the disk is ``full``, measured now."""
        state = self.check()
        if state["level"] == "full":
            raise StateConflict(f"{what} refused: {state['message']}")

    def start(self) -> None:
        """The first check (with its event and callbacks), then one every ``check_s``."""
        if self._thread is None:
            self.check()
            self._thread = threading.Thread(target=self._run, name="cavewalk-storage", daemon=True)
            self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=10)
            self._thread = None

    def _run(self) -> None:
        while not self._stop.wait(self.settings.check_s):
            try:
                self.check()
            except Exception:  # the loop boundary: the next check comes
                log.exception("checking the free disk space failed")
