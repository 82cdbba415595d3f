"""Supervision of the worker processes.

Workers come in groups that live and die together: one group per camera (its capture
worker) and one processing chain (pose detection + fusion, or simulator + fusion,
joined by queues). When a worker of a group dies without having ended on purpose, the
group is stopped, built afresh by its ``build`` callback (new queues, so a message cut
in half by the crash cannot jam anything) and started again after a back-off; the
other groups go on. A worker that reports ``ended`` and exits 0 (a video played once)
is not restarted.

:meth:`Supervisor.stop` sets every stop flag, joins, then terminates and finally kills
whatever is left, so no worker outlives the pipeline.
"""

from __future__ import annotations

import logging
import os
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from pipeline.runtime.messages import WorkerEvent
from pipeline.runtime.workers import worker_main

log = logging.getLogger(__name__)

WorkerDef = tuple[str, Callable[..., None], tuple[Any, ...]]  # (name, loop body, body args)


@dataclass(frozen=True, slots=True)
class SupervisorConfig:
    backoff_s: float = 0.5
    max_backoff_s: float = 5.0
    stable_after_s: float = 10.0  # a group that ran this long starts its back-off afresh
    join_timeout_s: float = 3.0

    def __post_init__(self) -> None:
        if self.backoff_s <= 0 or self.max_backoff_s < self.backoff_s or self.join_timeout_s <= 0:
            raise ValueError(f"invalid supervisor timings: {self}")


@dataclass
class WorkerGroup:
    name: str
    build: Callable[[], list[WorkerDef]]
    stop: Any = None
    processes: list[Any] = field(default_factory=list)
    started_at: float = 0.0
    restarts: int = 0
    restart_at: float | None = None
    ended: set[str] = field(default_factory=set)
    finished: bool = False
    defs: list[WorkerDef] = field(default_factory=list)  # keeps the queues alive while children start


class Supervisor:
    """Starts, watches and restarts worker groups; thread-safe."""

    def __init__(self, mp_context: Any, events: Any, config: SupervisorConfig | None = None) -> None:
        self._mp = mp_context
        self.events = events
        self.config = config or SupervisorConfig()
        self._groups: dict[str, WorkerGroup] = {}
        self._lock = threading.RLock()
        self._stopping = False

    def add_group(self, name: str, build: Callable[[], list[WorkerDef]]) -> None:
        with self._lock:
            if name in self._groups:
                raise ValueError(f"worker group {name!r} exists already")
            group = WorkerGroup(name, build)
            self._groups[name] = group
            self._start(group)

    def _start(self, group: WorkerGroup) -> None:
        group.stop = self._mp.Event()
        group.processes = []
        group.ended = set()
        group.started_at = time.monotonic()
        group.defs = group.build()
        for wname, body, args in group.defs:
            proc = self._mp.Process(
                target=worker_main, name=f"cavewalk-{wname}",
                args=(wname, body, self.events, group.stop, os.getpid(), *args), daemon=True,
            )
            proc.start()
            group.processes.append(proc)
        log.info("started %s (pids %s)", group.name, [p.pid for p in group.processes])

    def _halt(self, group: WorkerGroup) -> None:
        if group.stop is not None:
            group.stop.set()
        deadline = time.monotonic() + self.config.join_timeout_s
        for proc in group.processes:
            proc.join(max(0.0, deadline - time.monotonic()))
        for proc in group.processes:
            if proc.is_alive():
                proc.terminate()
                proc.join(1.0)
            if proc.is_alive():
                proc.kill()
                proc.join(1.0)
            proc.close()
        group.processes = []
        group.defs = []

    def note_event(self, event: WorkerEvent) -> None:
        """Let the supervisor see a worker's event (``ended`` marks a worker as done on purpose)."""
        if event.kind == "ended":
            with self._lock:
                for group in self._groups.values():
                    if any(p.name == f"cavewalk-{event.worker}" for p in group.processes):
                        group.ended.add(event.worker)

    def check(self) -> list[WorkerEvent]:
        """Restart dead groups that are due; returns events about what happened."""
        out: list[WorkerEvent] = []
        now = time.monotonic()
        with self._lock:
            if self._stopping:
                return out
            for group in self._groups.values():
                if group.finished:
                    continue
                if group.restart_at is not None:
                    if now >= group.restart_at:
                        group.restart_at = None
                        group.restarts += 1
                        self._start(group)
                        out.append(WorkerEvent(group.name, "info", f"{group.name} restarted "
                                               f"(restart {group.restarts})"))
                    continue
                dead = [p for p in group.processes if not p.is_alive()]
                if not dead:
                    continue
                crashed = [p for p in dead if not (p.exitcode == 0 and p.name.removeprefix("cavewalk-")
                                                   in group.ended)]
                if not crashed:
                    if len(dead) == len(group.processes):
                        group.finished = True
                        out.append(WorkerEvent(group.name, "ended", f"{group.name} finished"))
                    continue
                codes = ", ".join(f"{p.name.removeprefix('cavewalk-')} exit {p.exitcode}" for p in crashed)
                self._halt(group)
                if now - group.started_at > self.config.stable_after_s:
                    group.restarts = 0
                delay = min(self.config.max_backoff_s, self.config.backoff_s * 2 ** group.restarts)
                group.restart_at = now + delay
                out.append(WorkerEvent(group.name, "error", f"{group.name} died ({codes}); "
                                       f"restarting in {delay:.1f} s"))
                log.warning("%s died (%s); restarting in %.1f s", group.name, codes, delay)
        return out

    def pids(self) -> list[int]:
        with self._lock:
            return [p.pid for g in self._groups.values() for p in g.processes if p.pid is not None]

    def workers(self) -> dict[str, int]:
        """Worker name -> pid of the running processes."""
        with self._lock:
            return {p.name.removeprefix("cavewalk-"): p.pid for g in self._groups.values()
                    for p in g.processes if p.pid is not None}

    def group_alive(self, name: str) -> bool:
        with self._lock:
            g = self._groups.get(name)
            return g is not None and any(p.is_alive() for p in g.processes)

    def stop(self) -> None:
        """Stop every group and wait for its processes; nothing is left running afterwards."""
        with self._lock:
            self._stopping = True
            groups = list(self._groups.values())
            for g in groups:
                if g.stop is not None:
                    g.stop.set()
            for g in groups:
                self._halt(g)
            self._groups.clear()
        drain(self.events)


def drain(q: Any) -> list[Any]:
    """Everything waiting in a queue, without blocking."""
    items = []
    while True:
        try:
            items.append(q.get_nowait())
        except (queue.Empty, OSError, ValueError):
            return items
