"""Kill the live pipeline's workers and measure the locomotion gap at a real UDP receiver.

Starts ``cavewalk demo`` (the simulator source) of the checkout given by ``--repo`` on free
ports, with its UDP stream sent to a receiver in this process, waits for locomotion, then
kills (SIGKILL) each victim in turn and measures, from the datagrams' receive times:

- ``gap_s``: the longest interval between two locomotion datagrams around the kill (the
  emitter repeats the last command for ``emitter.stale_after_s``, so this hides up to 1 s);
- ``fresh_gap_s``: the longest interval between two datagrams that carry a new ``ts``
  (a new result of the pipeline), i.e. how long no new frame came through;
- ``states``: the heartbeat states seen until the stream was back.

Victims: ``simulator`` and ``fuse`` (worker processes) and ``forkserver`` (multiprocessing's
fork server). Workers are found by their process name (``cw-<worker>`` in /proc/PID/comm);
a checkout whose workers do not name themselves falls back to creation order (simulator,
then fuse). Two more are no kills but the operator's *Restart now*: ``restart`` (``POST
/api/v1/pipeline/restart``: a new run of the same pipeline) and ``rebuild`` (the active model
activated again first: a new pipeline, as for a new calibration or model).

    python scripts/runtime_faults.py --repo /tmp/rt-before --out before.json
    python scripts/runtime_faults.py --out after.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import psutil

ROOT = Path(__file__).resolve().parents[1]
VICTIMS = ("simulator", "fuse", "forkserver", "restart", "rebuild")
RESTARTS = ("restart", "rebuild")  # the operator's Restart now, not a kill
FLOWING_GAP_S = 1.0  # results are flowing (again) when none is further apart than this
TAG = f"{os.getpid()}-{time.time_ns()}"  # in the server's environment: finds its workers, orphans too


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


class Receiver:
    """Every datagram with its receive time (time.monotonic), in a thread."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.2)
        self.port = int(self.sock.getsockname()[1])
        self.items: list[tuple[float, dict[str, Any]]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                data, _ = self.sock.recvfrom(65536)
            except TimeoutError:
                continue
            except OSError:
                return
            try:
                msg = json.loads(data)
            except ValueError:
                continue
            self.items.append((time.monotonic(), msg))

    def since(self, t0: float, kind: str) -> list[tuple[float, dict[str, Any]]]:
        return [(t, m) for t, m in list(self.items) if t >= t0 and m.get("type") == kind]

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        self.sock.close()


def workers(server: psutil.Process) -> dict[str, int]:
    """victim name -> pid among the server's descendants."""
    out: dict[str, int] = {}
    forkserver = None
    for child in server.children():
        try:
            if "forkserver" in " ".join(child.cmdline()):
                forkserver = child
        except psutil.Error:
            continue
    if forkserver is None:
        return out
    out["forkserver"] = forkserver.pid
    unnamed = []
    for proc in psutil.process_iter(["pid", "name", "create_time"]):
        name = proc.info["name"] or ""
        if name.startswith("cw-") and proc.pid != server.pid:
            try:
                if proc.status() != psutil.STATUS_ZOMBIE and _ancestor_or_orphan(proc, server):
                    out[name.removeprefix("cw-")] = proc.pid
            except psutil.Error:
                continue
    if "fuse" not in out:  # an old checkout: workers are not named; order of creation
        for proc in forkserver.children():
            try:
                unnamed.append((proc.create_time(), proc.pid))
            except psutil.Error:
                continue
        unnamed.sort()
        for name, (_, pid) in zip(("simulator", "fuse"), unnamed, strict=False):
            out[name] = pid
    return out


def _ancestor_or_orphan(proc: psutil.Process, server: psutil.Process) -> bool:
    try:
        return proc.environ().get("CAVEWALK_FAULTS_TAG") == TAG or server in proc.parents()
    except psutil.Error:
        return False


def longest_gap(times: list[float]) -> float:
    return max((b - a for a, b in itertools.pairwise(times)), default=float("inf"))


def restart(api: str, rebuild: bool) -> None:
    """The dashboard's Restart now; ``rebuild``: after activating the active model again."""
    import httpx

    if rebuild:
        active = httpx.get(f"{api}/models/active", timeout=30).json()
        httpx.post(f"{api}/models/{active['id']}/activate", timeout=30).raise_for_status()
    httpx.post(f"{api}/pipeline/restart", timeout=60).raise_for_status()


def kill_and_measure(
    rx: Receiver, server: psutil.Process, victim: str, settle_s: float, timeout_s: float, api: str
) -> dict[str, Any]:
    pid = None
    before = time.monotonic() - 1.0
    if victim in RESTARTS:
        t_kill = time.monotonic()
        restart(api, victim == "rebuild")
    else:
        pids = workers(server)
        if victim not in pids:
            return {"victim": victim, "error": f"not found among {pids}"}
        pid = pids[victim]
        os.kill(pid, signal.SIGKILL)
        t_kill = time.monotonic()
    recovered = None
    deadline = t_kill + timeout_s
    while time.monotonic() < deadline:  # back when new results have flowed for settle_s
        time.sleep(0.2)
        fresh = _fresh(rx.since(t_kill, "locomotion"))
        if (
            fresh
            and fresh[-1] - fresh[0] >= settle_s
            and longest_gap([t for t in fresh if t >= fresh[-1] - settle_s]) < FLOWING_GAP_S
        ):
            recovered = fresh[0]
            break
    end = time.monotonic()
    loco = [t for t, _ in rx.since(before, "locomotion") if t <= end]
    fresh_times = [t for t in _fresh(rx.since(before, "locomotion")) if t <= end]
    if recovered is not None and len(fresh_times) > 1:  # back: the first new result after the longest gap
        i = max(range(1, len(fresh_times)), key=lambda k: fresh_times[k] - fresh_times[k - 1])
        recovered = fresh_times[i]
    states = []
    for _, m in rx.since(t_kill, "heartbeat"):
        if not states or states[-1] != m.get("state"):
            states.append(m.get("state"))
        if recovered is not None and _ > recovered + settle_s:
            break
    if recovered is None:  # never back: the gap runs to the end of the wait
        loco.append(end)
        fresh_times.append(end)
    return {
        "victim": victim,
        "pid": pid,
        "gap_s": round(longest_gap(loco), 3),
        "fresh_gap_s": round(longest_gap(fresh_times), 3),
        "back_after_kill_s": None if recovered is None else round(recovered - t_kill, 3),
        "recovered": recovered is not None,
        "states": states,
    }


def _fresh(items: list[tuple[float, dict[str, Any]]]) -> list[float]:
    out, last = [], None
    for t, m in items:
        if m.get("ts") != last:
            out.append(t)
            last = m.get("ts")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repo", type=Path, default=ROOT, help="checkout to run (default: this one)")
    ap.add_argument("--victims", default=",".join(VICTIMS))
    ap.add_argument("--rounds", type=int, default=1, help="kills per victim")
    ap.add_argument("--settle", type=float, default=3.0, help="seconds of flowing results between kills")
    ap.add_argument("--timeout", type=float, default=40.0, help="longest wait for recovery per kill")
    ap.add_argument("--out", type=Path, help="write the results as JSON here too")
    args = ap.parse_args()
    repo = args.repo.resolve()
    rx = Receiver()
    tmp = Path(tempfile.mkdtemp(prefix="cw-faults-"))
    env = dict(os.environ, PYTHONPATH=str(repo), CAVEWALK_SERVER__VISER="false", CAVEWALK_FAULTS_TAG=TAG)
    port = free_port()
    cmd = [
        sys.executable,
        "-m",
        "app.cli",
        "demo",
        "--port",
        str(port),
        "--db",
        str(tmp / "f.db"),
        "--emit",
        f"127.0.0.1:{rx.port}",
    ]
    log = open(tmp / "server.log", "w")  # noqa: SIM115
    proc = subprocess.Popen(
        cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
    )
    results: dict[str, Any] = {
        "repo": str(repo),
        "commit": _commit(repo),
        "cpu": _cpu(),
        "load_before": os.getloadavg(),
        "kills": [],
    }
    try:
        server = psutil.Process(proc.pid)
        t0 = time.monotonic()
        while time.monotonic() - t0 < 180:
            time.sleep(0.5)
            fresh = _fresh(rx.since(t0, "locomotion"))
            if len(fresh) > 30 and fresh[-1] - fresh[-30] < 6:
                break
        else:
            raise SystemExit(f"no locomotion within 180 s; see {tmp / 'server.log'}")
        time.sleep(args.settle)
        for _ in range(args.rounds):
            for victim in args.victims.split(","):
                res = kill_and_measure(rx, server, victim, args.settle, args.timeout,
                                       f"http://127.0.0.1:{port}/api/v1")
                print(json.dumps(res), flush=True)
                results["kills"].append(res)
    finally:
        results["load_after"] = os.getloadavg()
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
        rx.close()
        log.close()
        results["server_log"] = str(tmp / "server.log")
    print(json.dumps(results, indent=1))
    if args.out:
        args.out.write_text(json.dumps(results, indent=1) + "\n")


def _commit(repo: Path) -> str:
    try:
        return subprocess.run(
            ["git", "-C", str(repo), "rev-parse", "--short", "HEAD"],
            capture_output=True,
            text=True,
            check=False,
        ).stdout.strip()
    except OSError:
        return ""


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return f"{line.split(':', 1)[1].strip()} x{os.cpu_count()}"
    except OSError:
        pass
    return ""


if __name__ == "__main__":
    main()
