"""The locomotion stream under dashboard load, measured at a real UDP receiver (issue 15, load).

Starts ``cavewalk demo`` (the simulator source) of the checkout given by ``--repo`` on free
ports, waits for locomotion, then for ``--duration`` seconds runs ``--http`` HTTP clients
(each a loop of ``GET /api/v1/status`` and ``GET /api/v1/pipeline``, at most ``--http-rate``
requests a second each: bounded, as a dashboard is) and ``--ws`` WebSocket clients on
``/api/v1/ws/live``, while a receiver in its own process (no GIL shared with the clients)
records every datagram. It reports, the way ``cavewalk bench`` does:

- ``udp.locomotion_per_s``: locomotion datagrams a second at the receiver; ``udp.fresh_per_s``:
  those that carry a new result (a new ``ts``);
- ``udp.longest_gap_s`` / ``udp.longest_fresh_gap_s``: the longest silence of each;
- ``http.p50_ms`` / ``p95_ms`` and ``ws.messages_per_s_per_client``.

    python scripts/load_test.py --duration 20 --out load.json
    python scripts/load_test.py --repo /tmp/rt-before --duration 20
"""

from __future__ import annotations

import argparse
import asyncio
import itertools
import json
import multiprocessing as mp
import os
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from runtime_faults import free_port  # noqa: E402


def _receiver(port_q: Any, stop: Any, out_q: Any) -> None:
    """(receive time, type, ts) of every datagram until ``stop``; in its own process."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.2)
    port_q.put(sock.getsockname()[1])
    got: list[tuple[float, str, float]] = []
    while not stop.is_set():
        try:
            data, _ = sock.recvfrom(65536)
        except TimeoutError:
            continue
        t = time.monotonic()
        try:
            msg = json.loads(data)
            got.append((t, str(msg.get("type")), float(msg.get("ts") or 0.0)))
        except (ValueError, TypeError):
            continue
    out_q.put(got)


def udp_figures(got: list[tuple[float, str, float]], t0: float, t1: float) -> dict[str, Any]:
    loco = [(t, ts) for t, kind, ts in got if kind == "locomotion" and t0 <= t <= t1]
    times = [t for t, _ in loco]
    fresh = [t for (t, ts), prev in zip(loco, [None, *[x[1] for x in loco]], strict=False) if ts != prev]
    span = t1 - t0

    def gap(ts: list[float]) -> float:
        edges = [t0, *ts, t1]
        return max(b - a for a, b in itertools.pairwise(edges))

    return {
        "duration_s": round(span, 2),
        "locomotion": len(times),
        "locomotion_per_s": round(len(times) / span, 2),
        "fresh_per_s": round(len(fresh) / span, 2),
        "longest_gap_s": round(gap(times), 3),
        "longest_fresh_gap_s": round(gap(fresh), 3),
        "heartbeats": sum(1 for t, kind, _ in got if kind == "heartbeat" and t0 <= t <= t1),
    }


class Clients:
    """Bounded HTTP and WebSocket clients of the dashboard's API."""

    def __init__(self, port: int, http: int, ws: int, http_rate: float) -> None:
        self.base = f"127.0.0.1:{port}"
        self.http, self.ws, self.period = http, ws, 1.0 / http_rate
        self.latencies_ms: list[float] = []
        self.errors = 0
        self.ws_messages = [0] * ws
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []

    def start(self) -> None:
        for i in range(self.http):
            t = threading.Thread(target=self._http_client, args=(i,), daemon=True)
            self._threads.append(t)
        if self.ws:
            self._threads.append(
                threading.Thread(target=lambda: asyncio.run(self._ws_clients()), daemon=True)
            )
        for t in self._threads:
            t.start()

    def stop(self) -> None:
        self._stop.set()
        for t in self._threads:
            t.join(10)

    def _http_client(self, i: int) -> None:
        paths = ("/api/v1/status", "/api/v1/pipeline")
        n = 0
        while not self._stop.is_set():
            t = time.monotonic()
            try:
                with urllib.request.urlopen(f"http://{self.base}{paths[(i + n) % 2]}", timeout=30) as r:
                    r.read()
                self.latencies_ms.append((time.monotonic() - t) * 1000.0)
            except OSError:
                self.errors += 1
            n += 1
            self._stop.wait(max(0.0, self.period - (time.monotonic() - t)))

    async def _ws_clients(self) -> None:
        import websockets  # the WebSocket client (installed with the server's extras)

        async def one(i: int) -> None:
            try:
                async with websockets.connect(f"ws://{self.base}/api/v1/ws/live", open_timeout=30) as ws:
                    while not self._stop.is_set():
                        try:
                            await asyncio.wait_for(ws.recv(), timeout=0.5)
                            self.ws_messages[i] += 1
                        except TimeoutError:
                            continue
            except (OSError, websockets.WebSocketException):
                self.errors += 1

        await asyncio.gather(*(one(i) for i in range(self.ws)))


def run_load(
    repo: Path,
    duration_s: float,
    http: int = 30,
    ws: int = 20,
    http_rate: float = 10.0,
    warmup_timeout_s: float = 180.0,
) -> dict[str, Any]:
    """Start the demo server of ``repo``, load it, return the figures (see the module docstring)."""
    ctx = mp.get_context("fork")
    port_q, out_q, stop = ctx.Queue(), ctx.Queue(), ctx.Event()
    rx = ctx.Process(target=_receiver, args=(port_q, stop, out_q), daemon=True)
    rx.start()
    udp_port = int(port_q.get(timeout=30))
    tmp = Path(tempfile.mkdtemp(prefix="cw-load-"))
    port = free_port()
    env = dict(os.environ, PYTHONPATH=str(repo))
    cmd = [
        sys.executable,
        "-m",
        "app.cli",
        "demo",
        "--port",
        str(port),
        "--viser-port",
        str(free_port()),
        "--db",
        str(tmp / "load.db"),
        "--emit",
        f"127.0.0.1:{udp_port}",
    ]
    with (tmp / "server.log").open("wb") as log:
        server = subprocess.Popen(
            cmd, cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True
        )
    result: dict[str, Any] = {
        "repo": str(repo),
        "http_clients": http,
        "ws_clients": ws,
        "http_rate_per_client": http_rate,
        "load_before": os.getloadavg(),
        "server_log": str(tmp / "server.log"),
    }
    clients = Clients(port, http, ws, http_rate)
    try:
        _wait_running(port, warmup_timeout_s)
        time.sleep(2.0)
        clients.start()
        time.sleep(1.0)  # the clients connect
        t0 = time.monotonic()
        time.sleep(duration_s)
        t1 = time.monotonic()
    finally:
        clients.stop()
        stop.set()
        got = out_q.get(timeout=30) if rx.is_alive() or not out_q.empty() else []
        rx.join(5)
        os.killpg(server.pid, signal.SIGINT)
        try:
            server.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(server.pid, signal.SIGKILL)
    lat = np.array(clients.latencies_ms) if clients.latencies_ms else np.array([np.nan])
    result["udp"] = udp_figures(got, t0, t1)
    result["http"] = {
        "requests": len(clients.latencies_ms),
        "errors": clients.errors,
        "p50_ms": round(float(np.percentile(lat, 50)), 1),
        "p95_ms": round(float(np.percentile(lat, 95)), 1),
    }
    per_s = [m / (t1 - t0 + 1.0) for m in clients.ws_messages]
    result["ws"] = {"messages_per_s_per_client": round(float(np.median(per_s)), 2) if per_s else None}
    result["load_after"] = os.getloadavg()
    return result


def _wait_running(port: int, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/v1/status", timeout=10) as r:
                if json.loads(r.read()).get("state") == "running":
                    return
        except OSError:
            pass
        time.sleep(0.5)
    raise SystemExit(f"the demo did not run within {timeout_s:.0f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repo", type=Path, default=ROOT, help="checkout to run (default: this one)")
    ap.add_argument("--duration", type=float, default=20.0)
    ap.add_argument("--http", type=int, default=30, help="HTTP clients")
    ap.add_argument("--ws", type=int, default=20, help="WebSocket clients")
    ap.add_argument(
        "--http-rate", type=float, default=10.0, help="requests a second per HTTP client, at most"
    )
    ap.add_argument("--out", type=Path)
    args = ap.parse_args()
    res = run_load(args.repo.resolve(), args.duration, args.http, args.ws, args.http_rate)
    print(json.dumps(res, indent=1))
    if args.out:
        args.out.write_text(json.dumps(res, indent=1) + "\n")


if __name__ == "__main__":
    main()
