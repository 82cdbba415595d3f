"""The pipeline's status: its state machine, its event log and the status snapshot.

One :class:`StatusBoard` per pipeline. Every state change goes through it (the façade's
start and stop, the router's first result, the supervision's stall and chain errors), so
the state, the standby emitter's heartbeats and the ``state`` events always agree; a change
asked for on behalf of a run that is no longer the current one is ignored.
"""

from __future__ import annotations

import math
import threading
import time
from collections import deque
from typing import Any

from pipeline.emitter.udp import UdpEmitter
from pipeline.navigation.config import NavigationConfig
from pipeline.navigation.views import navigation_record
from pipeline.results import FrameResult, action_record, person_record
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.run import Run
from pipeline.runtime.status import PipelineEvent, PipelineStatus, State

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
        with self._lock:
            run, state, error = self._run, self._state, self._last_error
        endpoints, sent = tuple(self.emitter.endpoints), self.emitter.sent
        if run is None:
            return PipelineStatus(state, None, 0.0, 0, 0, RuntimeMetrics().latency_summary(), (), (),
                                  None, "auto", None, (), -1, error, endpoints, sent,
                                  navigation_record(None, navigation))
        now = time.monotonic()
        latest = run.latest
        result = latest.result if latest is not None else FrameResult(-1, 0.0)
        processed = run.metrics.processed
        people = tuple({"user_id": p.user_id, "position_m": [_f(v) for v in p.position_m],
                        "reproj_px": _f(p.reproj_px)} for p in result.people3d)
        return PipelineStatus(
            state=state, source=run.source, fps=round(run.metrics.fps.rate(now), 2),
            dropped=max(0, run.produced - processed), processed=processed,
            latency_ms=run.metrics.latency_summary(),
            cameras=tuple({"name": c.name, "ok": c.ok, "fps": round(c.fps, 2), "last_error": c.last_error}
                          for c in run.cameras.values()),
            people=people, navigator=result.navigator,
            navigator_mode=latest.navigator_mode if latest is not None else "auto",
            action=action_record(result.action), people3d=tuple(person_record(p) for p in result.people3d),
            frame_index=result.frame_index, last_error=error, workstations=endpoints, emitted=sent,
            navigation=navigation_record(result.navigation, navigation),
        )


def _f(x: float) -> float | None:
    return round(float(x), 4) if math.isfinite(float(x)) else None
