"""The session script's auto-stop: a running session with a planned run time is stopped by the server.

The timer lives in the server, not in a browser tab, so a closed dashboard does not leave a session
running; a server restarted mid-session picks the timer up again (or stops an overdue session).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable

from sqlalchemy.orm import Session

from app.db import repositories as repo
from app.db.models import StudySession
from app.services.event_log import EventWriter

log = logging.getLogger(__name__)


class SessionTimer:
    """One ``threading.Timer`` per running session that has a ``planned_duration_s``."""

    def __init__(self, session_factory: Callable[[], Session], events: EventWriter,
                 on_stop: Callable[[int], None] = lambda _session_id: None) -> None:
        self._factory = session_factory
        self._events = events
        self._on_stop = on_stop  # e.g. the participant's teach adaptation comes off
        self._timers: dict[int, threading.Timer] = {}
        self._lock = threading.Lock()

    def schedule(self, session: StudySession) -> None:
        if session.planned_duration_s is None or session.started_at is None or session.status != "running":
            return
        remaining = session.started_at.timestamp() + session.planned_duration_s - time.time()
        timer = threading.Timer(max(0.0, remaining), self._fire, (session.id,))
        timer.daemon = True
        with self._lock:
            old = self._timers.pop(session.id, None)
            self._timers[session.id] = timer
        if old is not None:
            old.cancel()
        timer.start()
        log.info("session %d stops by itself in %.0f s", session.id, max(0.0, remaining))

    def cancel(self, session_id: int) -> None:
        with self._lock:
            timer = self._timers.pop(session_id, None)
        if timer is not None:
            timer.cancel()

    def _fire(self, session_id: int) -> None:
        with self._lock:
            self._timers.pop(session_id, None)
        self._events.flush()
        try:
            with self._factory() as db:
                repo.stop_session(db, session_id, time.time(), by="timer")
        except repo.StateConflict:
            return  # stopped by hand meanwhile
        except Exception:
            log.exception("could not stop session %d at the end of its run time", session_id)
            return
        self._on_stop(session_id)  # its events (a controller session's hold released) still go to it
        if self._events.session_id == session_id:
            self._events.set_session(None)
        log.info("session %d stopped at the end of its run time", session_id)

    def close(self) -> None:
        with self._lock:
            timers, self._timers = list(self._timers.values()), {}
        for t in timers:
            t.cancel()
