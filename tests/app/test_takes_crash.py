"""A take survives a crash: `cavewalk demo` killed with SIGKILL mid-take; the next start recovers it."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import httpx
import numpy as np
import pytest

from pipeline.runtime.shm import PREFIXES, mapped_segments
from pipeline.takes.files import check_files
from tests.pipeline.runtime.live import shm_segments
from tests.waiting import free_port

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]


def _start(command: str, db: Path, port: int) -> subprocess.Popen[str]:
    cmd = [
        sys.executable,
        "-m",
        "app.cli",
        command,
        "--db",
        str(db),
        "--port",
        str(port),
        "--viser-port",
        str(free_port()),
    ]
    # its own process group: the kill takes the server and its pipeline workers, nothing else
    return subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True
    )


def _wait(url: str, ok, timeout_s: float = 300.0) -> dict:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + timeout_s
    last: object = None
    while time.monotonic() < deadline:
        try:
            last = httpx.get(url, timeout=5).json()
            if ok(last):
                return last  # type: ignore[return-value]
        except httpx.HTTPError as exc:
            last = exc
        time.sleep(0.3)
    raise AssertionError(f"{url} never matched; last: {last}")


def test_kill_9_mid_take_loses_at_most_the_last_second_and_recovers_as_incomplete(tmp_path: Path) -> None:
    db, port = tmp_path / "crash.db", free_port()
    base = f"http://127.0.0.1:{port}/api/v1"
    before = shm_segments(PREFIXES)
    server = _start("demo", db, port)
    try:
        _wait(f"{base}/status", lambda s: s["state"] == "running" and s["navigator"] is not None)
        r = httpx.post(f"{base}/takes", json={"participant_code": "K9", "protocol": "four-actions"})
        assert r.status_code == 201, r.text
        take = r.json()
        cur = _wait(f"{base}/takes/current", lambda c: c["recording"] and c["frames"] >= 20)
        time.sleep(1.2)  # what was written by `cur` reaches the disk within flush_interval_s (0.5 s)
    finally:
        os.killpg(server.pid, signal.SIGKILL)
        server.wait(timeout=30)
    # the killed run's shared memory (its workers and tracker died too); a run of another test
    # process at the same time (pytest -n) maps its own
    left = shm_segments(PREFIXES) - before - mapped_segments()
    folder = tmp_path / "takes" / take["uid"]
    assert json.loads((folder / "take.json").read_text())["complete"] is False
    assert not (folder / "skeletons.npz").exists(), "the crash came before the take was finished"

    server = _start("serve", db, port)
    try:
        row = _wait(f"{base}/takes/{take['id']}", lambda t: t["status"] != "recording")
    finally:
        os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=60)
    assert row["status"] == "incomplete", row
    assert left, "the kill left the run's mailboxes in /dev/shm"
    assert not left & shm_segments(PREFIXES), "the next start removed what the crashed run left in /dev/shm"
    assert row["frames"] >= cur["frames"], (
        f"recovered {row['frames']} frames; {cur['frames']} were written 1.2 s before the kill"
    )
    manifest = json.loads((folder / "take.json").read_text())
    assert manifest["complete"] is False and manifest["status"] == "incomplete"
    assert check_files(folder) == [], "every recovered file matches its sha256"
    with np.load(folder / "skeletons.npz") as npz:
        assert len(npz["t"]) == row["frames"]
        uid = int(npz["user_id"])
        assert npz[f"labels_{uid}"][0] == "still", "the protocol's labels up to the crash"
