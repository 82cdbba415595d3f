"""The result router: every fused result, in the main process (issue 16, item 3).

The collector thread takes each :class:`~pipeline.runtime.messages.FusedFrame` from the
fusion worker's mailbox, in order, measures its stages' latency (the fusion worker stamped
when its stream had it, ``sent_s``), keeps the run's newest result and counters, hands the
result to every main-process sink (``on_result``: the take recorder, ...) and turns its
navigator and action changes into events. The UDP stream is not here: the fusion worker
sends it (:class:`~pipeline.runtime.sinks.StreamSink`).
"""

from __future__ import annotations

import logging
import threading
import time

from pipeline.navigation.navigators import NavigationFrame
from pipeline.results import action_record
from pipeline.runtime.board import StatusBoard
from pipeline.runtime.messages import FusedFrame
from pipeline.runtime.run import Run
from pipeline.runtime.sinks import ResultSink

log = logging.getLogger(__name__)


class ResultRouter:
    """The collector loop and the main-process sinks; thread-safe."""

    def __init__(self, board: StatusBoard) -> None:
        self._board = board
        self._lock = threading.Lock()
        self._sinks: tuple[ResultSink, ...] = ()
        self._last_action: str | None = None

    # -- sinks -----------------------------------------------------------------------------
    def add(self, sink: ResultSink) -> None:
        with self._lock:
            if sink not in self._sinks:
                self._sinks = (*self._sinks, sink)

    def remove(self, sink: ResultSink) -> None:
        with self._lock:
            self._sinks = tuple(s for s in self._sinks if s is not sink)

    # -- the collector thread -------------------------------------------------------------------
    def begin(self) -> None:
        """A new run: no action seen yet."""
        self._last_action = None

    def collect(self, run: Run) -> None:
        """The collector thread's body: until the run stops."""
        box = run.out_box
        while not run.stop.is_set() and box is not None:
            try:
                got = box.get_all(timeout=0.1)  # every result in order: each may carry events
            except (OSError, ValueError, TypeError):  # the run is being torn down
                return
            except Exception:  # a message that does not unpickle
                log.exception("bad message from the fusion worker")
                continue
            for fused in got:
                if isinstance(fused, FusedFrame):
                    try:
                        self.on_result(run, fused)
                    except Exception:
                        log.exception("handling a result failed")

    def on_result(self, run: Run, fused: FusedFrame) -> None:
        result, det = fused.result, fused.detected
        sent = fused.sent_s if fused.sent_s is not None else fused.fuse_end_s  # the fusion worker sent it
        ms = {
            "capture": det.detect_start_s - det.timestamp_s,
            "detect": det.detect_end_s - det.detect_start_s,
            "fuse": fused.fuse_end_s - det.detect_end_s,
            "emit": sent - fused.fuse_end_s,
            "end_to_end": sent - det.timestamp_s,
        }
        now = time.monotonic()
        run.count_source_index(det.source_index)
        run.metrics.frame(now, {k: v * 1000.0 for k, v in ms.items()}, 0)
        run.latest = fused
        run.last_result_s = now
        run.note_people(result.people3d, now)
        run.supervisor.note_progress()
        for sink in self._sinks:  # each returns at once (queues its own work)
            try:
                sink.on_result(result)
            except Exception:
                log.exception("result sink %r failed", sink)
        self._board.transition(run, "running", ("starting", "error", "stalled"), "running",
                               {"state": "running", "source": run.source})
        self._events(fused)

    def _events(self, fused: FusedFrame) -> None:
        result, board = fused.result, self._board
        for change in fused.navigator_changes:
            board.event("navigator", f"navigator {change.previous} -> {change.current} ({change.reason})",
                        {"previous": change.previous, "current": change.current, "mode": change.mode})
        nav = result.navigation
        mode = nav.mode if nav is not None else "single"
        if nav is not None and mode != "single":
            self._navigation_events(nav, mode)
        label = result.action.label if result.action is not None else None
        if label != self._last_action and mode == "single":
            board.event("action", f"action {self._last_action} -> {label}",
                        {"previous": self._last_action, "label": label, "user_id": result.navigator,
                         "action": action_record(result.action)})
        self._last_action = label

    def _navigation_events(self, nav: NavigationFrame, mode: str) -> None:
        """Each person's own action changes (or the group's), in the ``each`` and ``group`` modes."""
        for c in nav.changes:
            who = "group" if c.user_id is None else f"user {c.user_id}"
            own = nav.command_of(c.user_id) if c.user_id is not None else None
            self._board.event("action", f"{who}: action {c.previous} -> {c.current} ({mode})",
                              {"previous": c.previous, "label": c.current, "user_id": c.user_id, "mode": mode,
                               "group": c.user_id is None,
                               "action": action_record(own.action if own is not None else None)})
