"""The live status, pushed (issue 16, item 4): one :class:`~pipeline.runtime.status.PipelineStatus`
to every subscriber, at most ``rate_hz`` times a second.

The pipeline pokes the publisher whenever what its status shows may have changed: each result
fusion hands on (the collector), each tick of the supervision thread (so a stalled run still
reports its health), each state change and event (so a stop is published at once). The
publisher's own thread builds the status and hands it to the subscribers, never sooner than
``1 / rate_hz`` after the previous one: that period is the one clock of the live status. With
nothing poked, nothing is published (a stopped pipeline is quiet). A subscriber's
``on_status`` runs on the publisher's thread and must return quickly (queue its own work).
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
    """Builds and pushes the status when poked, at most once per ``1 / rate_hz``; thread-safe."""

    def __init__(self, build: Callable[[], PipelineStatus], rate_hz: float = 10.0) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self._build = build
        self.period_s = 1.0 / rate_hz
        self._cond = threading.Condition()
        self._sinks: tuple[StatusSink, ...] = ()
        self._poked = False
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
            self._poked = True
            self._cond.notify()

    def unsubscribe(self, sink: StatusSink) -> None:
        with self._cond:
            self._sinks = tuple(s for s in self._sinks if s is not sink)

    def poke(self) -> None:
        """What the status shows may have changed: publish within the period."""
        with self._cond:
            if self._sinks and not self._poked:
                self._poked = True
                self._cond.notify()

    def publish_now(self) -> None:
        """Build and push the status at once, on the caller's thread (a start or stop that the
        caller waits for: its answer shows the new state)."""
        with self._cond:
            sinks = self._sinks
            self._poked = False
        if sinks:
            self._publish(sinks)

    def close(self) -> None:
        """Publish once more if poked, then stop the thread."""
        with self._cond:
            self._closed = True
            self._cond.notify()
            thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)

    def _run(self) -> None:
        while True:
            with self._cond:
                while not self._poked and not self._closed:
                    self._cond.wait()
                if not self._poked:  # closed with nothing new
                    return
                wait_s = self._last_s + self.period_s - time.monotonic()
                if wait_s > 0 and not self._closed:  # never sooner than one period after the last
                    self._cond.wait(wait_s)
                    continue  # woken early (a close): look again
                self._poked = False
                sinks = self._sinks
            self._publish(sinks)

    def _publish(self, sinks: tuple[StatusSink, ...]) -> None:
        with self._publishing:
            self._last_s = time.monotonic()
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
