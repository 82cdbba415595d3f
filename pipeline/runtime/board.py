"""The pipeline's status: its state machine, its event log and the status snapshot.

One :class:`StatusBoard` per pipeline. Every state change goes through it (the façade's
start and stop, the router's first result, the supervision's stall and chain errors), so
the state, the standby emitter's heartbeats and the ``state`` events always agree; a change
asked for on behalf of a run that is no longer the current one is ignored.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import replace
from typing import Any

from pipeline.emitter.udp import UdpEmitter
from pipeline.navigation.config import NavigationConfig
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.run import Run
from pipeline.runtime.status import (
    ActionStatus,
    CameraStatus,
    NavigationStatus,
    PipelineEvent,
    PipelineStatus,
    Skeleton,
    State,
    frame_people,
)

EVENT_LOG_SIZE = 2000


class StatusBoard:
    """State, last error, events; thread-safe."""

    def __init__(self, emitter: UdpEmitter) -> None:
        self.emitter = emitter
        self._lock = threading.RLock()
        self._state: State = "stopped"
        self._last_error: str | None = None
        self._run: Run | None = None
        self._events: deque[PipelineEvent] = deque(maxlen=EVENT_LOG_SIZE)
        emitter.set_state("stopped")

    @property
    def state(self) -> State:
        return self._state

    # -- the state machine ---------------------------------------------------------------
    def starting(self, source: str) -> None:
        with self._lock:
            self._run = None
            self._last_error = None
            self._set("starting", f"starting ({source})", {"state": "starting", "source": source})

    def started(self, run: Run) -> None:
        with self._lock:
            self._run = run

    def failed(self) -> None:
        """The start failed (the error went to the caller)."""
        with self._lock:
            self._run = None
            self._state = "error"

    def stopped(self) -> None:
        with self._lock:
            self._run = None
            self._set("stopped", "stopped", {"state": "stopped"})

    def transition(self, run: Run, to: State, from_: tuple[State, ...], message: str,
                   data: dict[str, Any]) -> bool:
        """``from_`` -> ``to`` for the current run ``run``; whether it changed."""
        with self._lock:
            if self._run is not run or self._state not in from_:
                return False
            self._set(to, message, data)
            return True

    def error(self, run: Run, worker: str, message: str) -> None:
        """A worker's error: the last error; the chain's (no results until it is back): ``error``."""
        with self._lock:
            self._last_error = f"{worker}: {message.splitlines()[0] if message else 'error'}"
            if worker == "chain" and self._run is run:
                self._state = "error"
                self.emitter.set_state("error")

    def _set(self, state: State, message: str, data: dict[str, Any]) -> None:
        self._state = state
        self.emitter.set_state(state)
        self.event("state", message, data)

    # -- events ----------------------------------------------------------------------------
    def event(self, kind: str, message: str, data: dict[str, Any]) -> None:
        with self._lock:
            self._events.append(PipelineEvent(time.time(), kind, message, data))

    def drain(self) -> list[PipelineEvent]:
        with self._lock:
            out = list(self._events)
            self._events.clear()
            return out

    # -- the snapshot -----------------------------------------------------------------------
    def status(self, navigation: NavigationConfig) -> PipelineStatus:
        """The status now: the run's health and its newest fused frame (``navigation``: the
        configured mode, shown while no frame says otherwise)."""
        with self._lock:
            run, state, error = self._run, self._state, self._last_error
        endpoints, sent, held = tuple(self.emitter.endpoints), self.emitter.sent, self.emitter.held
        if run is None:
            return PipelineStatus(state, latency_ms=RuntimeMetrics().latency_summary(), last_error=error,
                                  workstations=endpoints, emitted=sent,
                                  navigation=NavigationStatus.of(None, navigation), held=held)
        latest = run.latest
        processed = run.metrics.processed
        health = PipelineStatus(
            state, run.source, round(run.metrics.fps.rate(time.monotonic()), 2),
            max(0, run.produced - processed), processed, run.metrics.latency_summary(),
            tuple(CameraStatus(c.name, c.ok, round(c.fps, 2), c.last_error) for c in run.cameras.values()),
            navigation=NavigationStatus.of(None, navigation), last_error=error, workstations=endpoints,
            emitted=sent, held=held)
        if latest is None:
            return health
        result = latest.result
        return replace(
            health, people=frame_people(result), navigator=result.navigator,
            navigator_mode="manual" if latest.navigator_mode == "manual" else "auto",
            navigation=NavigationStatus.of(result.navigation, navigation),
            action=ActionStatus.of(result.action) if result.action is not None else None,
            people3d=tuple(Skeleton.of(p) for p in result.people3d), frame_index=result.frame_index)
