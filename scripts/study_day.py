#!/usr/bin/env python
"""A study day against a real server: every session of a planned study run as an experimenter and
a participant's tablet would, while a dashboard watches and a workstation listens.

    .venv/bin/python scripts/study_day.py --participants 30 --run-s 75 --json day.json
    .venv/bin/python scripts/study_day.py --participants 2 --run-s 5        # shortened

Starts ``cavewalk demo`` (the simulated CAVE, the real server, worker processes, database, backups
and log file) on a fresh database in ``--folder`` (default: a new temporary folder), sending its UDP
stream to a socket of this script. Plans ``--participants`` participants (both sessions each, the
run ``--run-s`` seconds). For each session in the planned order it makes a participant link and
answers, through the tablet's API with that link's credential, every questionnaire that is due
(answers drawn within each instrument's own scale); when the run is due the operator starts the
session and the server's timer stops it. All the while: one live WebSocket kept open, one opened
again every ``--reload-s`` seconds (a dashboard tab reloaded), ``GET /status`` every second, the
UDP stream checked datagram by datagram (:class:`ReceiverStats`, as ``cavewalk receive`` does),
and the resident memory of the server and each of its processes sampled every ``--every`` s.

At the end the server is stopped with Ctrl+C (SIGINT) and the day is checked; exit status 0 when
every check holds, 1 otherwise:

- every session ran and was stopped by the server's timer;
- every answer sent was stored (201) and the server holds exactly those sheets, once each;
- the newest backup (the server's own, at its stop) holds every sheet too and passes
  ``PRAGMA quick_check``;
- the server stopped cleanly (exit status 0) and its log file has no ``ERROR`` or traceback;
- no UDP datagram was invalid or out of order, and the stream never went quiet for longer than
  ``--max-quiet-s`` (the heartbeat keeps it going between sessions);
- the main process grew less than ``--max-growth-mb`` after the warm-up.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import random
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any
from urllib.parse import urlsplit

import httpx
import numpy as np
import psutil
import websockets

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from runtime_faults import free_port  # noqa: E402

from app.db.backup import BackupError, inspect_database, list_backups  # noqa: E402
from pipeline.emitter.receiver import ReceiverStats  # noqa: E402
from pipeline.machine import machine_facts  # noqa: E402

API = "/api/v1"


class DayAborted(Exception):
    """The day could not go on (the server refused or stopped answering): a failed check."""


def sheet(definition: dict[str, Any], rng: random.Random) -> tuple[dict[str, Any], dict[str, str] | None]:
    """Answers to every item of one instrument within its own scale (and every pairwise choice)."""
    answers: dict[str, Any] = {}
    for item in definition["items"]:
        if item.get("allow") and rng.random() < 0.1:
            answers[item["key"]] = item["allow"][0]
        else:
            answers[item["key"]] = rng.randint(int(item["min"]), int(item["max"]))
    pairs = definition.get("pairs") or []
    pairwise = {p["key"]: rng.choice(p["options"]) for p in pairs} or None
    return answers, pairwise


class Watchers:
    """The dashboard (live WebSockets, status polls), the workstation (UDP) and the memory sampler."""

    def __init__(self, base: str, udp: socket.socket, proc: psutil.Process, every_s: float, reload_s: float):
        self.base, self.udp, self.proc = base, udp, proc
        self.every_s, self.reload_s = every_s, reload_s
        self.stop = threading.Event()
        self.counts = {"live_messages": 0, "reloads": 0, "status": 0, "errors": 0}
        self.errors: list[str] = []
        self.stream = ReceiverStats()
        self.longest_quiet_s = 0.0
        self.samples: list[dict[str, Any]] = []
        self.t0 = time.time()
        self._threads = [
            threading.Thread(target=f, daemon=True)
            for f in (self._udp, self._polls, self._live, self._memory)
        ]

    def start(self) -> None:
        for th in self._threads:
            th.start()

    def finish(self) -> None:
        self.stop.set()
        for th in self._threads:
            th.join(timeout=10)

    def _error(self, what: str) -> None:
        self.counts["errors"] += 1
        if len(self.errors) < 20:
            self.errors.append(what)

    def _udp(self) -> None:
        self.udp.settimeout(0.2)
        last = time.time()
        while not self.stop.is_set():
            try:
                data, addr = self.udp.recvfrom(65535)
            except OSError:
                self.longest_quiet_s = max(self.longest_quiet_s, time.time() - last)
                continue
            now = time.time()
            self.longest_quiet_s = max(self.longest_quiet_s, now - last)
            last = now
            self.stream.feed(data, f"{addr[0]}:{addr[1]}", now)

    def _polls(self) -> None:
        with httpx.Client(timeout=10) as client:
            while not self.stop.wait(1.0):
                try:
                    client.get(self.base + API + "/status").raise_for_status()
                    self.counts["status"] += 1
                except httpx.HTTPError as exc:
                    self._error(f"status: {exc!r}")

    def _live(self) -> None:
        asyncio.run(self._live_async())

    async def _live_async(self) -> None:
        url = self.base.replace("http://", "ws://") + API + "/ws/live"

        async def keep() -> None:
            while not self.stop.is_set():
                try:
                    async with websockets.connect(url, max_size=None, origin=self.base) as ws:
                        while not self.stop.is_set():
                            await asyncio.wait_for(ws.recv(), timeout=10)
                            self.counts["live_messages"] += 1
                except (OSError, TimeoutError, websockets.WebSocketException) as exc:
                    if not self.stop.is_set():
                        self._error(f"live: {exc!r}")
                        await asyncio.sleep(1)

        async def reload() -> None:
            while not self.stop.is_set():
                try:
                    async with websockets.connect(url, max_size=None, origin=self.base) as ws:
                        for _ in range(3):
                            await asyncio.wait_for(ws.recv(), timeout=10)
                    self.counts["reloads"] += 1
                except (OSError, TimeoutError, websockets.WebSocketException) as exc:
                    self._error(f"reload: {exc!r}")
                await asyncio.sleep(self.reload_s)

        await asyncio.gather(keep(), reload())

    def _memory(self) -> None:
        while not self.stop.wait(self.every_s):
            row: dict[str, Any] = {"t_s": round(time.time() - self.t0, 1)}
            try:
                row["main"] = round(self.proc.memory_info().rss / 2**20, 1)
                for child in self.proc.children(recursive=True):
                    with contextlib.suppress(psutil.Error):
                        row[f"{child.name()[:24]}-{child.pid}"] = round(child.memory_info().rss / 2**20, 1)
            except psutil.Error:
                return
            self.samples.append(row)


def growth(samples: list[dict[str, Any]], key: str, warmup_s: float) -> dict[str, float] | None:
    """A process's resident memory after the warm-up: first, last, and the fitted slope (MB/h)."""
    pts = [(s["t_s"], s[key]) for s in samples if key in s and s["t_s"] >= warmup_s]
    if len(pts) < 3:
        return None
    t, mb = np.array(pts).T
    slope = float(np.polyfit(t / 3600.0, mb, 1)[0])
    return {
        "first_mb": float(mb[0]),
        "last_mb": float(mb[-1]),
        "growth_mb": round(float(mb[-1] - mb[0]), 1),
        "slope_mb_per_h": round(slope, 2),
    }


def run_session(client: httpx.Client, sid: int, run_s: float, rng: random.Random) -> dict[str, Any]:
    """One session as the operator and the participant's tablet go through it."""
    link = client.post(f"{API}/sessions/{sid}/participant-link")
    link.raise_for_status()
    token = urlsplit(link.json()["url"]).fragment.removeprefix("t=")
    tablet = {"X-Participant-Token": token}
    instruments = client.get(f"{API}/participant/instruments", headers=tablet).json()
    sent: list[tuple[str, str | None]] = []
    refused: list[str] = []
    while True:
        view = client.get(f"{API}/participant/session", headers=tablet).json()
        step = next((s for s in view["steps"] if s["key"] == view["current"]), None)
        if step is None:
            break
        if step["kind"] == "run":
            started = client.post(f"{API}/sessions/{sid}/start")
            started.raise_for_status()
            deadline = time.time() + run_s + 60
            while client.get(f"{API}/sessions/{sid}").json()["status"] != "stopped":
                if time.time() > deadline:
                    raise DayAborted(f"session {sid} was not stopped by the server's timer")
                time.sleep(0.5)
            continue
        answers, pairwise = sheet(instruments[step["instrument"]], rng)
        body = {"instrument": step["instrument"], "phase": step["phase"], "answers": answers}
        if pairwise is not None:
            body["pairwise"] = pairwise
        r = client.post(f"{API}/participant/questionnaires", headers=tablet, json=body)
        if r.status_code != 201:
            refused.append(f"{step['key']}: {r.status_code} {r.text[:200]}")
            break
        sent.append((step["instrument"], step["phase"]))
    session = client.get(f"{API}/sessions/{sid}").json()
    return {
        "session_id": sid,
        "status": session["status"],
        "stopped_by": session.get("stopped_by"),
        "sent": sent,
        "refused": refused,
    }


def check_backup(folder: Path, db: Path, sheets: int) -> dict[str, Any]:
    """The newest of ``db``'s backups in ``folder`` (by the time in its name): checked as
    ``cavewalk db restore`` checks it, and how many questionnaire sheets it holds."""
    backups = list_backups(folder, db)
    if not backups:
        return {"count": 0, "ok": False}
    newest = backups[0].path
    try:
        _, counts = inspect_database(newest)
    except BackupError as exc:
        return {"count": len(backups), "newest": newest.name, "error": str(exc), "ok": False}
    held = counts.get("questionnaire_responses", 0)
    return {
        "count": len(backups),
        "newest": newest.name,
        "quick_check": "ok",
        "sheets": held,
        "ok": held == sheets,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--participants", type=int, default=12, help="participants planned (two sessions each)"
    )
    parser.add_argument("--run-s", type=float, default=60.0, help="each session's run, seconds")
    parser.add_argument(
        "--folder", type=Path, default=None, help="where the database goes (default: a new temp folder)"
    )
    parser.add_argument("--every", type=float, default=20.0, help="seconds between memory samples")
    parser.add_argument(
        "--warmup", type=float, default=120.0, help="seconds of memory left out of the growth"
    )
    parser.add_argument("--reload-s", type=float, default=10.0, help="seconds between dashboard reloads")
    parser.add_argument("--max-growth-mb", type=float, default=50.0)
    parser.add_argument("--max-quiet-s", type=float, default=2.0, help="longest UDP silence allowed")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", type=Path, default=None, help="write the figures and samples here")
    args = parser.parse_args(argv)
    bad = [
        name for name, ok in (
            ("--participants", 1 <= args.participants <= 500),
            ("--run-s", 3.0 <= args.run_s <= 14_400),
            ("--every", 0.5 <= args.every <= 600),
            ("--warmup", args.warmup >= 0),
            ("--reload-s", args.reload_s > 0),
            ("--max-growth-mb", args.max_growth_mb > 0),
            ("--max-quiet-s", args.max_quiet_s > 0),
        ) if not ok
    ]  # fmt: skip
    if bad:
        print(f"error: out of range: {', '.join(bad)} (see --help)", file=sys.stderr)
        return 2
    folder = args.folder or Path(tempfile.mkdtemp(prefix="study-day-"))
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        print(f"error: --folder {folder}: {exc.strerror or exc}", file=sys.stderr)
        return 2
    db = folder / "study.db"
    if db.exists():
        print(f"error: {db} exists: the day starts on a fresh database", file=sys.stderr)
        return 2
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind(("127.0.0.1", 0))
    port, viser_port = free_port(), free_port()
    out = (folder / "server.out").open("w")
    server = subprocess.Popen(
        [sys.executable, "-m", "app.cli", "demo", "--db", str(db), "--port", str(port),
         "--viser-port", str(viser_port), "--emit", f"127.0.0.1:{udp.getsockname()[1]}"],
        cwd=ROOT, stdout=out, stderr=subprocess.STDOUT,
    )  # fmt: skip
    base = f"http://127.0.0.1:{port}"
    t_start = time.time()
    rng = random.Random(args.seed)
    results: list[dict[str, Any]] = []
    watch: Watchers | None = None
    stored: dict[int, list[tuple[str, str | None]]] = {}
    aborted: str | None = None
    try:
        with httpx.Client(base_url=base, timeout=30) as client:
            while True:
                try:
                    if client.get(API + "/status").status_code == 200:
                        break
                except httpx.HTTPError:
                    pass
                if server.poll() is not None or time.time() - t_start > 180:
                    print(f"error: the server did not start (see {folder / 'server.out'})", file=sys.stderr)
                    return 1
                time.sleep(0.5)
            ready_s = time.time() - t_start
            watch = Watchers(base, udp, psutil.Process(server.pid), args.every, args.reload_s)
            watch.start()
            try:
                plan = client.post(
                    API + "/study/plan",
                    json={"participants": args.participants, "run_minutes": args.run_s / 60.0},
                )
                plan.raise_for_status()
                for person in plan.json()["participants"]:
                    for sid in person["session_ids"]:
                        results.append(run_session(client, sid, args.run_s, rng))
                        done = len(results)
                        print(
                            f"session {done}/{2 * args.participants} ({person['code']}): "
                            f"{results[-1]['status']}, {len(results[-1]['sent'])} sheets, "
                            f"{time.time() - t_start:.0f} s",
                            flush=True,
                        )
                stored = {
                    s["id"]: [(q["instrument"], q["phase"]) for q in
                              client.get(f"{API}/sessions/{s['id']}/questionnaires").json()]
                    for s in client.get(API + "/sessions").json()
                }  # fmt: skip
            except (httpx.HTTPError, DayAborted, KeyError, ValueError) as exc:
                aborted = f"{type(exc).__name__}: {exc}"
                print(f"the day stopped after {len(results)} sessions: {aborted}", file=sys.stderr)
    finally:
        if watch is not None:
            watch.finish()
        server.send_signal(signal.SIGINT)
        try:
            server_rc = server.wait(timeout=90)
        except subprocess.TimeoutExpired:
            server.kill()
            server_rc = -9
        out.close()
    sent_total = sum(len(r["sent"]) for r in results)
    log = folder / "logs" / "cavewalk.log"
    log_text = log.read_text(errors="replace") if log.exists() else ""
    bad_lines = [ln for ln in log_text.splitlines() if " ERROR " in ln or "Traceback" in ln]
    backup = check_backup(folder / "backups", db, sent_total)
    assert watch is not None
    keys = sorted({k for s in watch.samples for k in s if k != "t_s"})
    memory = {k: growth(watch.samples, k, args.warmup) for k in keys}
    main_growth = memory.get("main")
    checks = {
        "the day ran to its end": aborted is None and len(results) == 2 * args.participants,
        "every session stopped by the server's timer": all(
            r["status"] == "stopped" and r["stopped_by"] == "timer" for r in results
        ),
        "every sheet sent was stored, once": all(not r["refused"] for r in results)
        and all(sorted(stored.get(r["session_id"], [])) == sorted(r["sent"]) for r in results),
        "the newest backup holds every sheet": bool(backup["ok"]),
        "the server stopped cleanly": server_rc == 0,
        "no error in the log file": log.exists() and not bad_lines,
        "the UDP stream: none invalid, none out of order": watch.stream.invalid == 0
        and watch.stream.out_of_order == 0,
        f"the UDP stream never quiet for {args.max_quiet_s} s": watch.longest_quiet_s <= args.max_quiet_s,
        "the dashboard's connections never failed": watch.counts["errors"] == 0,
        f"the main process grew less than {args.max_growth_mb} MB": main_growth is not None
        and main_growth["growth_mb"] < args.max_growth_mb,
    }
    report = {
        "machine": {"cpu": machine_facts().summary(), "cores": psutil.cpu_count()},
        "participants": args.participants,
        "sessions": len(results),
        "run_s": args.run_s,
        "duration_s": round(time.time() - t_start, 1),
        "server_ready_s": round(ready_s, 2),
        "sheets_sent": sent_total,
        "aborted": aborted,
        "dashboard": dict(watch.counts),
        "dashboard_errors": watch.errors,
        "udp": {k: v for k, v in watch.stream.summary().items() if k not in ("navigation",)},
        "udp_longest_quiet_s": round(watch.longest_quiet_s, 3),
        "backup": backup,
        "server_exit": server_rc,
        "log_errors": bad_lines[:20],
        "memory": memory,
        "checks": checks,
        "folder": str(folder),
    }
    if args.json is not None:
        args.json.write_text(json.dumps({**report, "samples": watch.samples}, indent=2))
    print(
        json.dumps(
            {
                k: report[k]
                for k in (
                    "sessions",
                    "sheets_sent",
                    "duration_s",
                    "udp_longest_quiet_s",
                    "backup",
                    "memory",
                    "checks",
                )
            },
            indent=2,
        )
    )
    failed = [name for name, ok in checks.items() if not ok]
    for name in failed:
        print(f"error: check failed: {name}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
