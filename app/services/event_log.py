"""The event log writer: events are queued in memory and written to SQLite in batches.

A study day of 60 Hz action events must not slow the pipeline or the API, so
:meth:`EventWriter.record` only appends to a queue; a background thread inserts
what has gathered every ``flush_interval_s`` (at most one second, so a crash loses
at most the last second) and on :meth:`close`. Events recorded while a study session
is running carry that session's id.
"""

from __future__ import annotations

import logging
import queue
import threading
import time
from collections.abc import Callable
from typing import Any

from sqlalchemy.orm import Session

from app.db.repositories import add_events
from app.services.event_log_config import EventWriterConfig

log = logging.getLogger(__name__)


class _Flush:
    __slots__ = ("done",)

    def __init__(self) -> None:
        self.done = threading.Event()


class EventWriter:
    """Batches events into the ``events`` table from a background thread."""

    def __init__(self, session_factory: Callable[[], Session], config: EventWriterConfig | None = None):
        self._factory = session_factory
        self._config = config or EventWriterConfig()
        self._queue: queue.SimpleQueue[dict[str, Any] | _Flush | None] = queue.SimpleQueue()
        self._session_id: int | None = None
        self._session_since = 0.0
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self.written = 0
        self.failed = 0
        self._on_session: tuple[Callable[[], None], ...] = ()

    def on_session_change(self, callback: Callable[[], None]) -> None:
        """Call ``callback()`` after each :meth:`set_session` (the live status shows the session)."""
        self._on_session = (*self._on_session, callback)

    # -- producer side (any thread) ----------------------------------------------------
    @property
    def session_id(self) -> int | None:
        with self._lock:
            return self._session_id

    def set_session(self, session_id: int | None, since_ts: float = 0.0) -> None:
        """Events from now on, stamped at or after ``since_ts``, belong to this study session (None = none).

        An event that happened before the session started (the pipeline reports with a delay) does not.
        """
        with self._lock:
            self._session_id = session_id
            self._session_since = float(since_ts)
        for callback in self._on_session:
            callback()

    def record(self, kind: str, payload: dict[str, Any], ts: float | None = None) -> None:
        """Queue one event; never blocks on the database."""
        when = float(ts if ts is not None else time.time())
        with self._lock:
            sid = self._session_id if when >= self._session_since else None
        self._queue.put(
            {
                "session_id": sid,
                "ts": when,
                "kind": str(kind)[:32],
                "payload": payload,
            }
        )

    def flush(self, timeout_s: float = 5.0) -> bool:
        """Write everything queued so far before returning (True when done in time)."""
        if self._thread is None or not self._thread.is_alive():
            self._write(self._drain_now())
            return True
        marker = _Flush()
        self._queue.put(marker)
        return marker.done.wait(timeout_s)

    # -- lifecycle ---------------------------------------------------------------------
    def start(self) -> None:
        if self._thread is not None:
            return
        self._thread = threading.Thread(target=self._run, name="event-writer", daemon=True)
        self._thread.start()

    def close(self) -> None:
        """Write what is queued and stop the thread."""
        if self._thread is not None:
            self._queue.put(None)
            self._thread.join(timeout=10)
            self._thread = None
        self._write(self._drain_now())

    # -- consumer side -----------------------------------------------------------------
    def _drain_now(self) -> list[dict[str, Any]]:
        out: list[dict[str, Any]] = []
        while True:
            try:
                item = self._queue.get_nowait()
            except queue.Empty:
                return out
            if isinstance(item, dict):
                out.append(item)
            elif isinstance(item, _Flush):
                item.done.set()

    def _write(self, batch: list[dict[str, Any]]) -> None:
        if not batch:
            return
        try:
            with self._factory() as db:
                add_events(db, batch)
            self.written += len(batch)
        except Exception:
            self.failed += len(batch)
            log.exception("could not write %d events", len(batch))

    def _run(self) -> None:
        cfg = self._config
        batch: list[dict[str, Any]] = []
        markers: list[_Flush] = []
        deadline = time.monotonic() + cfg.flush_interval_s
        stopping = False
        while not stopping:
            timeout = max(0.0, deadline - time.monotonic())
            try:
                item = self._queue.get(timeout=timeout)
            except queue.Empty:
                item = _NOTHING
            if item is None:
                stopping = True
            elif isinstance(item, _Flush):
                markers.append(item)
            elif isinstance(item, dict):
                batch.append(item)
            now = time.monotonic()
            if stopping or markers or len(batch) >= cfg.max_batch or now >= deadline:
                self._write(batch)
                batch = []
                for m in markers:
                    m.done.set()
                markers = []
                deadline = now + cfg.flush_interval_s


_NOTHING: Any = object()
