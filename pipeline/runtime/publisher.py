"""The live status, pushed (issue 16, item 4): one :class:`~pipeline.runtime.status.PipelineStatus`
to every subscriber, ``rate_hz`` times a second.

The publisher's own thread is the one clock of the live status: every ``1 / rate_hz`` seconds
it builds the status (the run's health and the newest result fusion handed on) and hands it to
every subscriber; a start or stop publishes at once as well (:meth:`StatusPublisher.publish_now`,
so the caller's answer shows the new state). Nothing downstream keeps a clock of its own: the web
app hands each status to its WebSockets, its 3D view and its event log as it comes. A
subscriber's ``on_status`` runs on the publisher's thread (or the start's or stop's) and must
return quickly (queue its own work).
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Protocol

from pipeline.runtime.status import PipelineStatus

log = logging.getLogger(__name__)


class StatusSink(Protocol):
    """Gets every published status (the web app: its WebSockets, the 3D view, the event log)."""

    def on_status(self, status: PipelineStatus) -> None: ...


class StatusPublisher:
    """Builds and pushes the status every ``1 / rate_hz`` while it has subscribers; thread-safe."""

    def __init__(self, build: Callable[[], PipelineStatus], rate_hz: float = 10.0) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self._build = build
        self.period_s = 1.0 / rate_hz
        self._cond = threading.Condition()
        self._sinks: tuple[StatusSink, ...] = ()
        self._closed = False
        self._last_s = -float("inf")
        self._thread: threading.Thread | None = None
        self._publishing = threading.Lock()  # one status at a time, delivered in the order built

    def subscribe(self, sink: StatusSink) -> None:
        """``sink.on_status`` for every status from now on (the first one at once)."""
        with self._cond:
            if self._closed:
                raise RuntimeError("the status publisher is closed")
            if sink not in self._sinks:
                self._sinks = (*self._sinks, sink)
            if self._thread is None:
                self._thread = threading.Thread(target=self._run, name="cavewalk-status", daemon=True)
                self._thread.start()
            self._last_s = -float("inf")  # the new subscriber's first status: now
            self._cond.notify()

    def unsubscribe(self, sink: StatusSink) -> None:
        with self._cond:
            self._sinks = tuple(s for s in self._sinks if s is not sink)

    def publish_now(self) -> None:
        """Build and push the status at once, on the caller's thread (a start or stop that the
        caller waits for: its answer shows the new state); the clock goes on from here."""
        with self._cond:
            sinks = self._sinks
            if sinks:
                self._last_s = time.monotonic()
        if sinks:
            self._publish(sinks)

    def close(self) -> None:
        """Stop the clock (the statuses published so far were delivered)."""
        with self._cond:
            self._closed = True
            self._cond.notify()
            thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            with self._cond:
                if self._closed:
                    return
                wait_s = self._last_s + self.period_s - time.monotonic()
                if wait_s > 0:
                    self._cond.wait(wait_s)
                    continue  # due now, or woken (a close, a new subscriber): look again
                sinks = self._sinks
                # due from now, set with the sinks taken: a subscriber that comes after this sets
                # it back (its first status at once), which the publish below no longer undoes
                self._last_s = time.monotonic()
            self._publish(sinks)

    def _publish(self, sinks: tuple[StatusSink, ...]) -> None:
        with self._publishing:
            try:
                status = self._build()
            except Exception:  # the loop boundary: report, keep publishing
                log.exception("building the pipeline status failed")
                return
            for sink in sinks:
                try:
                    sink.on_status(status)
                except Exception:
                    log.exception("status subscriber %r failed", sink)
