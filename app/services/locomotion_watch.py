"""The alarm of a session with nobody steering: no locomotion command for more than 2 s.

:class:`LocomotionWatch` is a sink of the live status (it gets every status the pipeline pushes,
about ten a second while it runs). A locomotion command goes out while the pipeline runs and has a
navigator with an action (the emitter sends one per frame then). During a running study session a
gap longer than ``threshold_s`` raises the alarm: the dashboard shows it (``alarm`` in the live
status) and the session's log gets an ``alarm`` event when it is raised and when it clears, so the
session's summary can say how long it ran without commands.

The rule is also checked on the watch's own clock (:meth:`LocomotionWatch.start`, four times a
second), so the alarm is raised and logged when no status comes: with the pipeline stopped or
crashed during a running session. Each change of the alarm (raised, its gap grown, cleared) calls
``on_change``, so the live status shows it also while no pipeline status comes.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from app.services.event_log import EventWriter
from pipeline.runtime.status import PipelineStatus

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class WatchConfig:
    threshold_s: float = 2.0

    def __post_init__(self) -> None:
        if not self.threshold_s > 0:
            raise ValueError(f"threshold_s must be > 0, got {self.threshold_s}")


def sending(snapshot: Mapping[str, Any]) -> bool:
    """Whether the pipeline is sending locomotion commands in this status."""
    return (
        snapshot.get("state") == "running"
        and snapshot.get("navigator") is not None
        and snapshot.get("action") is not None
    )


def why_not(snapshot: Mapping[str, Any] | None) -> str:
    if snapshot is None or snapshot.get("state") in (None, "stopped", "unavailable"):
        return "the pipeline is not running"
    state = snapshot.get("state")
    if state != "running":
        return f"the pipeline is {state}"
    if snapshot.get("navigator") is None:
        if snapshot.get("navigator_mode") == "manual":
            return "no navigator: the operator's choice is lost"
        return "no navigator: nobody is tracked near the centre"
    return "no action recognised for the navigator"


class LocomotionWatch:
    """Raises and clears the no-locomotion alarm from the live status; logs both to the session."""

    def __init__(
        self,
        events: EventWriter,
        config: WatchConfig | None = None,
        clock: Callable[[], float] = time.monotonic,
        on_change: Callable[[], None] = lambda: None,
    ) -> None:
        self._events = events
        self._on_change = on_change
        self.config = config or WatchConfig()
        self._clock = clock
        self._lock = threading.Lock()
        self._session: int | None = None
        self._last_sent: float | None = None  # monotonic
        self._snapshot: Mapping[str, Any] | None = None
        self._snapshot_at = 0.0
        self._alarm: dict[str, Any] | None = None
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # -- its own clock -----------------------------------------------------------------
    def start(self, period_s: float = 0.25) -> None:
        """Check the rule every ``period_s`` on a daemon thread until :meth:`close`."""
        if self._thread is not None:
            return
        self._stop.clear()
        self._thread = threading.Thread(
            target=self._tick, args=(period_s,), name="locomotion-watch", daemon=True
        )
        self._thread.start()

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2)
            self._thread = None

    def _tick(self, period_s: float) -> None:
        while not self._stop.wait(period_s):
            try:
                self.current()
            except Exception:  # the loop boundary: a failed check must not end the watch
                log.exception("locomotion watch check failed")

    # -- the sink ----------------------------------------------------------------------
    def on_status(self, status: PipelineStatus, message: Mapping[str, Any]) -> None:
        """A live status pushed by the pipeline (its JSON form is what the rule reads)."""
        self.update(message)

    def update(self, snapshot: Mapping[str, Any]) -> None:
        with self._lock:
            before = self._alarm_now()
            self._snapshot, self._snapshot_at = snapshot, self._clock()
            self._check_locked()
            changed = self._alarm_now() != before
        if changed:
            self._on_change()

    # -- readers -----------------------------------------------------------------------
    def current(self) -> dict[str, Any] | None:
        """The alarm now (for the live status), or None."""
        with self._lock:
            before = self._alarm_now()
            self._check_locked()
            alarm = self._alarm_now()
        if alarm != before:
            self._on_change()
        return alarm

    def _alarm_now(self) -> dict[str, Any] | None:
        return dict(self._alarm) if self._alarm is not None else None

    # -- the rule ----------------------------------------------------------------------
    def _check_locked(self) -> None:
        now = self._clock()
        session = self._events.session_id
        if session != self._session:  # a session started or stopped: count from now
            if self._alarm is not None:
                self._clear(now, "session ended" if session is None else "another session started")
            self._session, self._last_sent = session, now
        if session is None:
            return
        snap = self._snapshot
        fresh = snap is not None and now - self._snapshot_at <= self.config.threshold_s
        if fresh and snap is not None and sending(snap):
            if self._alarm is not None:
                self._clear(now, "locomotion commands again")
            self._last_sent = now
            return
        last = self._last_sent if self._last_sent is not None else now
        gap = now - last
        if gap <= self.config.threshold_s:
            return
        reason = why_not(snap if fresh else None)
        if self._alarm is None:
            self._alarm = {
                "kind": "no_locomotion",
                "session_id": session,
                "since_ts": time.time() - gap,
                "gap_s": round(gap, 1),
                "reason": reason,
            }
            log.warning("session %d: no locomotion command for %.1f s (%s)", session, gap, reason)
            self._events.record(
                "alarm",
                {
                    "alarm": "no_locomotion",
                    "state": "raised",
                    "since_ts": self._alarm["since_ts"],
                    "reason": reason,
                    "navigator_mode": (snap or {}).get("navigator_mode"),
                },
            )
        else:
            self._alarm["gap_s"] = round(gap, 1)
            self._alarm["reason"] = reason

    def _clear(self, now: float, why: str) -> None:
        alarm = self._alarm
        self._alarm = None
        if alarm is None:
            return
        gap = now - (self._last_sent if self._last_sent is not None else now)
        log.info("session %s: %s after %.1f s", alarm["session_id"], why, gap)
        self._events.record(
            "alarm",
            {
                "alarm": "no_locomotion",
                "state": "cleared",
                "since_ts": alarm["since_ts"],
                "gap_s": round(gap, 1),
                "why": why,
            },
        )
