"""Faults of a real ``cavewalk serve``/``demo`` process (issue 15 D9, shutdown, resource tracker).

Each test runs the server as a subprocess of its own process group, on free ports, and drives
it through its HTTP API and through signals, as an operator's shell or a service manager does.
Deadlines are generous (the machine may be busy): they wait for an outcome, they time nothing.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
import urllib.request
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import psutil
import pytest

from pipeline.demo_data import DemoData
from pipeline.runtime.shm import SHM_PREFIX
from tests.pipeline.runtime.live import segments_of, shm_segments, shrink_video
from tests.waiting import free_port

ROOT = Path(__file__).resolve().parents[3]
pytestmark = pytest.mark.slow



def _wait(cond: Callable[[], bool], timeout_s: float, what: str) -> None:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(0.2)


@dataclass
class Server:
    proc: subprocess.Popen[bytes]
    port: int
    log: Path

    def api(self, method: str, path: str, body: object | None = None) -> dict[str, object]:
        data = None if body is None else json.dumps(body).encode()
        req = urllib.request.Request(
            f"http://127.0.0.1:{self.port}/api/v1{path}",
            data=data,
            method=method,
            headers={"content-type": "application/json"},
        )
        with urllib.request.urlopen(req, timeout=30) as resp:
            return json.loads(resp.read())  # type: ignore[no-any-return]

    def state(self) -> str:
        try:
            return str(self.api("GET", "/status")["state"])
        except OSError:
            return "down"

    def output(self) -> str:
        return self.log.read_text(errors="replace")

    def descendants(self) -> list[psutil.Process]:
        return psutil.Process(self.proc.pid).children(recursive=True)


@pytest.fixture()
def server(tmp_path: Path) -> Iterator[Callable[[str], Server]]:
    started: list[Server] = []

    def start(command: str) -> Server:
        port = free_port()
        log = tmp_path / f"{command}-{len(started)}.log"
        env = dict(os.environ, PYTHONPATH=str(ROOT), CAVEWALK_SERVER__VISER="false")
        with log.open("wb") as out:
            proc = subprocess.Popen(
                [sys.executable, "-m", "app.cli", command, "--port", str(port), "--db",
                 str(tmp_path / f"{len(started)}.db")],
                cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True,
            )  # fmt: skip
        srv = Server(proc, port, log)
        started.append(srv)
        # generous: start-up imports the web app and the pipeline on what may be a busy machine
        _wait(lambda: srv.state() != "down" or proc.poll() is not None, 120, "the server to answer")
        assert proc.poll() is None, srv.output()
        return srv

    yield start
    for srv in started:
        if srv.proc.poll() is None:
            os.killpg(srv.proc.pid, signal.SIGKILL)
            srv.proc.wait(30)


def _running(srv: Server) -> None:
    _wait(lambda: srv.state() == "running", 180, "the pipeline to run")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_shutdown_signal_to_the_group_restarts_nothing_and_prints_no_traceback(
    server: Callable[[str], Server], sig: signal.Signals
) -> None:
    srv = server("demo")
    _running(srv)
    workers = [p.pid for p in srv.descendants()]
    os.killpg(srv.proc.pid, sig)  # what a service manager (SIGTERM) or Ctrl-C in a terminal (SIGINT) does
    srv.proc.wait(60)
    out = srv.output()
    assert "Traceback" not in out, out
    assert "restarting" not in out and "died" not in out, out
    _wait(
        lambda: (
            not any(
                psutil.pid_exists(p) and psutil.Process(p).status() != psutil.STATUS_ZOMBIE for p in workers
            )
        ),
        30,
        "every worker to end",
    )


def test_kill_9_of_the_server_leaves_no_worker_and_no_shared_memory(
    server: Callable[[str], Server], demo_data: DemoData, tmp_path: Path
) -> None:
    videos = {
        cam: str(shrink_video(demo_data.videos[cam], tmp_path / f"{cam}.mp4", 60))
        for cam in ("cam01", "cam02")
    }
    srv = server("serve")
    srv.api("POST", "/pipeline/start", {"source": "videos", "videos": videos})
    _running(srv)
    ours = segments_of(srv.proc.pid, SHM_PREFIX)  # this server's (other test processes run pipelines too)
    assert len(ours) >= 2, "a ring per camera"
    children = srv.descendants()
    assert len(children) >= 4, children  # capture x2, detect, fuse (+ the fork server, resource tracker)
    os.kill(srv.proc.pid, signal.SIGKILL)
    srv.proc.wait(30)
    t0 = time.monotonic()

    def gone() -> bool:
        alive = [p for p in children if p.is_running() and p.status() != psutil.STATUS_ZOMBIE]
        return not alive and not (shm_segments() & ours)

    # the workers look for their parent every 0.25 s; 30 s is generous (it measures nothing)
    _wait(gone, 30, "every child to end and every ring to be unlinked")
    print(f"children and rings gone {time.monotonic() - t0:.2f} s after kill -9")


def test_a_dead_resource_tracker_gives_no_keyerror_tracebacks(server: Callable[[str], Server]) -> None:
    srv = server("demo")
    _running(srv)
    tracker = [p for p in srv.descendants() if "resource_tracker" in " ".join(p.cmdline())]
    assert tracker, "the server runs a resource tracker"
    os.kill(tracker[0].pid, signal.SIGKILL)
    for _ in range(2):  # each stop frees, each start makes, the run's named semaphores
        srv.api("POST", "/pipeline/stop")
        srv.api("POST", "/pipeline/start", {"source": "simulator"})
        _running(srv)
    srv.api("POST", "/pipeline/stop")
    os.killpg(srv.proc.pid, signal.SIGINT)
    srv.proc.wait(60)
    out = srv.output()
    assert "KeyError" not in out and "Traceback" not in out, out
