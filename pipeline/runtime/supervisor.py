"""Supervision of the worker processes.

Workers come in groups: one group per camera (its capture worker) and one processing
chain (pose detection + fusion, or simulator + fusion, joined by queues). What happens
when a worker dies without having ended on purpose:

- **one worker of a group whose others still run** is started again alone, at once, on
  the same queues (the others keep their state: fusion keeps its tracks when the
  simulator dies, the simulator keeps going while fusion comes back), except the arguments
  made afresh for each start (:class:`PerSpawn`: a queue only that worker reads, whose
  reader lock the killed worker may have held). Should the group
  then make no progress for ``partial_grace_s`` (a message cut in half by the crash could
  jam a queue), the whole group is rebuilt on fresh queues;
- **every worker of a group** dead: the group is built afresh by its ``build`` callback
  (new queues) and started again;
- the first restart after a stable run is immediate; a worker that keeps dying backs off
  (``backoff_s`` doubling up to ``max_backoff_s``);
- **the fork server killed**: multiprocessing then reports every worker as dead (exit
  255) although they still run; such workers are kept and watched by pid, and a new fork
  server is started for later restarts, so nothing stops;
- a worker **stopped by SIGTERM** (a shutdown signal to the process group) is restarted
  only after ``sigterm_grace_s``, without a warning, so that a shutdown under way restarts
  nothing; :meth:`Supervisor.stop` ends all restarting.

A worker that reports ``ended`` and exits 0 (a video played once) is not restarted.
:meth:`Supervisor.stop` sets every stop flag, joins, then terminates and finally kills
whatever is left, so no worker outlives the pipeline.
"""

from __future__ import annotations

import contextlib
import logging
import multiprocessing.synchronize as mps
import os
import queue
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from multiprocessing import spawn
from multiprocessing.process import BaseProcess
from typing import Any

import psutil

from pipeline.runtime.logfile import LogFileConfig
from pipeline.runtime.messages import BoundedQueue, T, WorkerEvent
from pipeline.runtime.workers import SIGTERM_EXIT, worker_main

log = logging.getLogger(__name__)

WorkerDef = tuple[str, Callable[..., None], tuple[Any, ...]]  # (name, loop body, body args)


@dataclass(frozen=True, slots=True)
class PerSpawn:
    """A worker argument made afresh by ``make()`` each time the worker starts, also when it is
    started again alone: a queue only that worker reads. A worker killed inside ``get`` holds the
    queue's reader lock for ever, so a successor on the same queue would never read it again."""

    make: Callable[[], Any]

FORKSERVER_LOST = 255  # the exit code multiprocessing reports when the fork server's pipe closed


@dataclass(frozen=True, slots=True)
class SupervisorConfig:
    backoff_s: float = 0.5
    max_backoff_s: float = 5.0
    stable_after_s: float = 10.0  # a group that ran this long starts its back-off afresh
    join_timeout_s: float = 3.0
    partial_grace_s: float = 15.0  # no progress this long after a lone restart: rebuild the group
    sigterm_grace_s: float = 2.0

    def __post_init__(self) -> None:
        if self.backoff_s <= 0 or self.max_backoff_s < self.backoff_s or self.join_timeout_s <= 0:
            raise ValueError(f"invalid supervisor timings: {self}")


class Worker:
    """One worker process; also watched by pid once multiprocessing lost track of it (fork server died)."""

    def __init__(self, name: str, proc: BaseProcess) -> None:
        self.name = name
        self.proc = proc
        self.pid: int | None = proc.pid
        self._orphan: psutil.Process | None = None

    @property
    def orphaned(self) -> bool:
        return self._orphan is not None

    def alive(self) -> bool:
        if self._orphan is not None:
            try:
                return self._orphan.is_running() and self._orphan.status() != psutil.STATUS_ZOMBIE
            except psutil.Error:
                return False
        if self.proc.is_alive():
            return True
        if self.proc.exitcode == FORKSERVER_LOST and self.pid is not None:
            try:  # the fork server died, not necessarily the worker
                p = psutil.Process(self.pid)
                if p.status() != psutil.STATUS_ZOMBIE:
                    self._orphan = p
                    return True
            except psutil.Error:
                pass
        return False

    @property
    def exitcode(self) -> int | None:
        if self._orphan is not None:
            return None if self.alive() else FORKSERVER_LOST
        return self.proc.exitcode

    def join(self, timeout: float) -> None:
        if self._orphan is None:
            self.proc.join(timeout)
            return
        with contextlib.suppress(psutil.Error):
            self._orphan.wait(timeout)

    def signal(self, sig: int) -> None:
        if self._orphan is not None:
            with contextlib.suppress(psutil.Error):
                self._orphan.send_signal(sig)
        elif sig == signal.SIGKILL:
            self.proc.kill()
        else:
            self.proc.terminate()

    def close(self) -> None:
        with contextlib.suppress(ValueError):  # still running (an orphan that would not die)
            self.proc.close()


@dataclass
class WorkerGroup:
    name: str
    build: Callable[[], list[WorkerDef]]
    stop: mps.Event | None = None
    workers: list[Worker] = field(default_factory=list)
    started_at: float = 0.0
    restarts: int = 0
    restart_at: float | None = None
    restart_only: set[str] | None = None  # the workers a due restart starts (None: the whole group)
    ended: set[str] = field(default_factory=set)
    terminated: set[str] = field(default_factory=set)  # stopped by SIGTERM
    finished: bool = False
    defs: list[WorkerDef] = field(default_factory=list)  # the queues, alive while the group is
    partial_at: float | None = None  # when a worker was restarted alone (progress is awaited)


class Supervisor:
    """Starts, watches and restarts worker groups; thread-safe."""

    def __init__(self, mp_context: Any, events: BoundedQueue[WorkerEvent],
                 config: SupervisorConfig | None = None, log: LogFileConfig | None = None) -> None:
        self._mp = mp_context
        self.events = events
        self.config = config or SupervisorConfig()
        self.log = log  # the server's log file, which each worker appends to
        self._groups: dict[str, WorkerGroup] = {}
        self._lock = threading.RLock()
        self._stopping = False
        self._progress_s = 0.0

    def add_group(self, name: str, build: Callable[[], list[WorkerDef]]) -> None:
        with self._lock:
            if name in self._groups:
                raise ValueError(f"worker group {name!r} exists already")
            group = WorkerGroup(name, build)
            self._groups[name] = group
            self._start(group)

    def note_progress(self) -> None:
        """The chain produced a result (a lone restart worked)."""
        self._progress_s = time.monotonic()

    # -- starting and halting ---------------------------------------------------------------
    def _start(self, group: WorkerGroup) -> None:
        group.stop = self._mp.Event()
        group.workers = []
        group.ended = set()
        group.terminated = set()
        group.started_at = time.monotonic()
        group.partial_at = None
        group.defs = group.build()
        for wdef in group.defs:
            group.workers.append(self._spawn(group, wdef))
        log.info("started %s (pids %s)", group.name, [w.pid for w in group.workers])

    def _spawn(self, group: WorkerGroup, wdef: WorkerDef) -> Worker:
        wname, body, args = wdef
        args = tuple(a.make() if isinstance(a, PerSpawn) else a for a in args)
        proc = self._mp.Process(
            target=worker_main, name=f"cavewalk-{wname}",
            args=(wname, body, self.events, group.stop, os.getpid(), *args), kwargs={"log": self.log},
            daemon=True,
        )
        with without_main_module():
            proc.start()
        return Worker(wname, proc)

    def _restart_alone(self, group: WorkerGroup, names: set[str]) -> None:
        for i, worker in enumerate(group.workers):
            if worker.name in names:
                worker.close()
                wdef = next(d for d in group.defs if d[0] == worker.name)
                group.workers[i] = self._spawn(group, wdef)
                group.ended.discard(worker.name)
                group.terminated.discard(worker.name)
        group.partial_at = time.monotonic()
        group.started_at = group.partial_at

    def _halt(self, group: WorkerGroup) -> None:
        if group.stop is not None:
            group.stop.set()
        deadline = time.monotonic() + self.config.join_timeout_s
        for w in group.workers:
            w.join(max(0.0, deadline - time.monotonic()))
        for w in group.workers:
            for sig in (signal.SIGTERM, signal.SIGKILL):
                if w.alive():
                    w.signal(sig)
                    w.join(1.0)
            w.close()
        group.workers = []
        group.defs = []

    # -- watching ------------------------------------------------------------------------------
    def note_event(self, event: WorkerEvent) -> None:
        """Let the supervisor see a worker's event (``ended``: done on purpose; ``stopped`` after SIGTERM)."""
        if event.kind not in ("ended", "stopped"):
            return
        with self._lock:
            for group in self._groups.values():
                if any(w.name == event.worker and w.pid == event.pid for w in group.workers) or (
                        event.pid == 0 and any(w.name == event.worker for w in group.workers)):
                    if event.kind == "ended":
                        group.ended.add(event.worker)
                    elif event.message.startswith("terminated"):
                        group.terminated.add(event.worker)

    def check(self) -> list[WorkerEvent]:
        """Restart dead workers that are due; returns events about what happened."""
        out: list[WorkerEvent] = []
        now = time.monotonic()
        with self._lock:
            if self._stopping:
                return out
            for group in self._groups.values():
                if not group.finished:
                    self._check_group(group, now, out)
        return out

    def _check_group(self, group: WorkerGroup, now: float, out: list[WorkerEvent]) -> None:
        if group.restart_at is not None:
            if now >= group.restart_at:
                self._restart_due(group, out)
            return
        if (group.partial_at is not None and len(group.workers) > 1 and self._progress_s < group.partial_at
                and now - group.partial_at > self.config.partial_grace_s):
            out.append(WorkerEvent(group.name, "error", f"{group.name} died (no progress "
                                   f"{self.config.partial_grace_s:.0f} s after a restart); rebuilding"))
            self._halt(group)
            group.restart_at, group.restart_only = now, None
            return
        if group.partial_at is not None and self._progress_s >= group.partial_at:
            group.partial_at = None
        if any(w.orphaned for w in group.workers) or any(not w.alive() and w.exitcode == FORKSERVER_LOST
                                                         for w in group.workers):
            self._replace_forkserver()
        dead = [w for w in group.workers if not w.alive()]
        if not dead:
            return
        crashed = [w for w in dead if not (w.exitcode == 0 and w.name in group.ended)]
        if not crashed:
            if len(dead) == len(group.workers):
                group.finished = True
                out.append(WorkerEvent(group.name, "ended", f"{group.name} finished"))
            return
        self._schedule(group, crashed, dead, now, out)

    def _schedule(self, group: WorkerGroup, crashed: list[Worker], dead: list[Worker], now: float,
                  out: list[WorkerEvent]) -> None:
        codes = ", ".join(f"{w.name} exit {w.exitcode}" for w in crashed)
        if now - group.started_at > self.config.stable_after_s:
            group.restarts = 0
        delay = 0.0 if group.restarts == 0 else min(self.config.max_backoff_s,
                                                     self.config.backoff_s * 2 ** (group.restarts - 1))
        by_sigterm = all(w.exitcode == SIGTERM_EXIT or w.exitcode == -signal.SIGTERM
                         or w.name in group.terminated for w in crashed)
        alone = len(dead) < len(group.workers)
        if by_sigterm:
            delay = max(delay, self.config.sigterm_grace_s)
        if alone:
            group.restart_only = {w.name for w in dead}
            who = ", ".join(sorted(group.restart_only))
            what = f"{who} died ({codes}); restarting {'it' if len(dead) == 1 else 'them'} alone"
        else:
            group.restart_only = None
            self._halt(group)
            what = f"{group.name} died ({codes}); restarting"
        group.restart_at = now + delay
        if by_sigterm:  # a shutdown under way: no warning (Supervisor.stop comes first)
            log.debug("%s in %.1f s (SIGTERM)", what, delay)
            return
        worker = crashed[0].name if alone and len(crashed) == 1 else group.name
        out.append(WorkerEvent(worker, "error", f"{what} in {delay:.1f} s"))
        log.warning("%s in %.1f s", what, delay)

    def _restart_due(self, group: WorkerGroup, out: list[WorkerEvent]) -> None:
        group.restart_at = None
        group.restarts += 1
        only = group.restart_only
        group.restart_only = None
        if only is not None and group.defs and all(w.name in only or w.alive() for w in group.workers):
            self._restart_alone(group, only)
            for name in sorted(only):
                out.append(WorkerEvent(name, "info", f"{name} restarted (restart {group.restarts})"))
            return
        if group.workers:
            self._halt(group)
        self._start(group)
        out.append(WorkerEvent(group.name, "info", f"{group.name} restarted (restart {group.restarts})"))

    def _replace_forkserver(self) -> None:
        """A new fork server for the next start, now (multiprocessing would start one on demand)."""
        if getattr(self._mp, "_name", None) != "forkserver":
            return
        from multiprocessing import forkserver  # the fork server's module, only under forkserver

        with contextlib.suppress(OSError), without_main_module():
            forkserver.ensure_running()

    # -- queries and stop ----------------------------------------------------------------------
    def pids(self) -> list[int]:
        with self._lock:
            return [w.pid for g in self._groups.values() for w in g.workers if w.pid is not None]

    def workers(self) -> dict[str, int]:
        """Worker name -> pid of the running processes."""
        with self._lock:
            return {w.name: w.pid for g in self._groups.values() for w in g.workers if w.pid is not None}

    def group_alive(self, name: str) -> bool:
        with self._lock:
            g = self._groups.get(name)
            return g is not None and any(w.alive() for w in g.workers)

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


@contextlib.contextmanager
def without_main_module() -> Iterator[None]:
    """Processes started in here do not import the parent's ``__main__`` first.

    Under spawn and forkserver a child runs the parent's main module again (``app.cli``
    for ``cavewalk serve``: the whole web app, seconds of imports on a busy machine) before
    its target; the workers need nothing from it (their code is in this package), so a
    worker that is (re)started runs at once.
    """
    original = spawn.get_preparation_data

    def preparation_data(name: str) -> dict[str, Any]:
        data = original(name)
        data.pop("init_main_from_name", None)
        data.pop("init_main_from_path", None)
        return data

    spawn.get_preparation_data = preparation_data  # type: ignore[assignment]
    try:
        yield
    finally:
        spawn.get_preparation_data = original  # type: ignore[assignment]


def drain(q: BoundedQueue[T] | None) -> list[T]:
    """Everything waiting in a queue (none: nothing), without blocking."""
    items: list[T] = []
    if q is None:
        return items
    while True:
        try:
            items.append(q.get_nowait())
        except (queue.Empty, OSError, ValueError):
            return items
