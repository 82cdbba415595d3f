"""``cavewalk receive`` and ``cavewalk bench`` as a user runs them (real processes and sockets)."""

from __future__ import annotations

import json
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from pipeline.emitter import EmitterConfig, LocomotionCommand, UdpEmitter
from pipeline.machine import machine_facts
from pipeline.runtime.shm import PREFIXES, mapped_segments
from tests.app.test_cli_errors import run_cli
from tests.pipeline.runtime.live import children_alive, segments_of, shm_segments
from tests.waiting import free_udp_port

ROOT = Path(__file__).resolve().parents[3]


def cavewalk(*args: str) -> list[str]:
    return [sys.executable, "-m", "app.cli", *args]


def wait_bound(port: int, proc: subprocess.Popen[str], timeout_s: float = 60.0) -> None:
    """Until the receiver holds the port (binding it ourselves then fails)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        assert proc.poll() is None, proc.communicate()
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.bind(("127.0.0.1", port))
            except OSError:
                return
        time.sleep(0.1)
    raise AssertionError("the receiver did not bind its port")


def test_receive_validates_counts_and_summarises() -> None:
    port = free_udp_port()
    proc = subprocess.Popen(cavewalk("receive", "--host", "127.0.0.1", "--port", str(port), "--count", "8",
                                     "--json"), cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        wait_bound(port, proc)
        emitter = UdpEmitter(EmitterConfig(rate_hz=60.0, heartbeat_s=0.05), [("127.0.0.1", port)])
        emitter.set_state("running")
        emitter.start()
        t0 = time.monotonic()
        while proc.poll() is None and time.monotonic() - t0 < 20:
            emitter.submit(LocomotionCommand(1, "right", 0.6, 90.0, 0.8, (0.0, 0.0, 0.0), time.monotonic()))
            time.sleep(0.02)
        emitter.close()
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    lines = [json.loads(line) for line in out.splitlines()]
    assert len(lines) == 9, "8 datagrams, then the summary"
    assert all(line["valid"] for line in lines[:8])
    summary = lines[-1]["summary"]
    assert summary["received"] == 8 and summary["invalid"] == 0 and summary["dropped"] == 0
    assert summary["by_type"].get("locomotion", 0) >= 1
    assert summary["latency_ms"] is not None and summary["latency_ms"]["p50"] >= 0


def test_receive_reports_invalid_datagrams_with_exit_1() -> None:
    port = free_udp_port()
    proc = subprocess.Popen(cavewalk("receive", "--host", "127.0.0.1", "--port", str(port), "--count", "2"),
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_bound(port, proc)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            good = b'{"v": 1, "type": "heartbeat", "seq": 0, "ts": 1.0, "state": "running"}'
            s.sendto(good, ("127.0.0.1", port))
            s.sendto(b'{"v": 2}', ("127.0.0.1", port))
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1
    assert "INVALID" in out and "v: expected 1" in err
    assert "1 valid, 1 invalid" in err


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("receive", "--port", "0"), "--port must be 1-65535"),
        (("receive", "--port", "9", "--count", "0"), "--count must be >= 1"),
        (("bench", "--source", "webcam"), "--source must be demo, sim or both"),
        (("bench", "--duration", "-1"), "--duration must be > 0"),
        (("bench", "--people", "5"), "--people must be 1-4"),
        (("bench", "--people", "2", "--navigation", "crowd"), "--navigation must be single, each or group"),
        (("bench", "--source", "demo", "--people", "2"), "--people needs the simulator"),
    ],
)
def test_bad_arguments_exit_2_with_one_line(args: tuple[str, ...], message: str,
                                           monkeypatch: pytest.MonkeyPatch,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    # the real entry point in this process (as tests/app/test_cli_errors.py runs its sixty cases): an
    # interpreter per case costs ~3 s of imports; an exception escaping main() fails the test
    rc = run_cli(list(args), monkeypatch)
    err = capsys.readouterr().err
    assert rc == 2, err
    assert err.strip().splitlines()[-1].startswith(f"error: {message}")
    assert "Traceback" not in err


@pytest.mark.slow
def test_bench_with_two_people_streams_each_navigator(tmp_path: Path) -> None:
    out = tmp_path / "bench.json"
    proc = subprocess.run(cavewalk("bench", "--source", "sim", "--people", "2", "--duration", "2", "--warmup",
                                   "1", "--json", str(out)),
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(out.read_text())
    assert list(report["scenarios"]) == ["sim_30fps_each_2p"], "--people replaces sim_60fps"
    sim = report["scenarios"]["sim_30fps_each_2p"]
    rx = sim["receiver"]
    assert rx["invalid"] == 0, rx["errors"]
    assert len(rx["by_user"]) == 2 and "group" not in rx["by_user"], f"two per-user streams: {rx['by_user']}"
    assert rx["by_type"].get("navigation", 0) >= 1 and sim["cpu_percent"]["mean"] > 0


@pytest.mark.slow
def test_bench_sim_writes_json(tmp_path: Path) -> None:
    out = tmp_path / "bench.json"
    proc = subprocess.run(cavewalk("bench", "--source", "sim", "--duration", "2", "--warmup", "0",
                                   "--json", str(out)),
                          cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    report = json.loads(out.read_text())
    sim = report["scenarios"]["sim_60fps"]
    assert sim["processed_frames"] > 0 and sim["processed_fps"] > 0
    assert set(sim["latency_ms"]) == {"capture", "detect", "fuse", "emit", "end_to_end"}
    assert sim["latency_ms"]["end_to_end"]["p95"] >= sim["latency_ms"]["end_to_end"]["p50"] > 0
    assert sim["cpu_percent"]["mean"] > 0 and sim["rss_mb"]["max"] > 0
    assert sim["receiver"]["invalid"] == 0 and sim["receiver"]["by_type"].get("heartbeat", 0) >= 1
    assert report["machine"]["cpus"] >= 1
    cpu = report["machine"]["cpu"]  # the machine the figures came from (issue 17 item 1)
    facts = machine_facts()
    assert cpu["cpu_model"] == facts.cpu_model and cpu["extensions"] == list(facts.extensions)
    assert cpu["logical_cores"] == facts.logical_cores and cpu["onnxruntime"] == facts.onnxruntime
    assert report["machine"]["execution_provider"] == "CPUExecutionProvider"
    assert report["machine"]["pose"]["precision"] in ("fp32", "int8")
    assert f"cpu: {facts.summary()}" in proc.stdout and "pose: CPUExecutionProvider" in proc.stdout
    assert "sim_60fps:" in proc.stdout and "end_to_end" in proc.stdout


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_signal_stops_bench_cleanly(sig: signal.Signals) -> None:
    # no warm-up: the signal comes once the first progress line shows the pipeline running
    proc = subprocess.Popen(cavewalk("bench", "--source", "sim", "--duration", "120", "--warmup", "0"),
                            cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stderr is not None
        deadline = time.monotonic() + 120
        for line in proc.stderr:
            if "[sim_60fps]" in line and "fps" in line and "processed" in line:
                break
            assert time.monotonic() < deadline, "bench did not start"
        workers = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
        assert workers, "the pipeline runs in worker processes"
        ours = segments_of(proc.pid)  # this run's (other test processes may run pipelines too)
        assert ours, "its mailboxes and stream book"
        proc.send_signal(sig)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    if sig == signal.SIGTERM:
        assert proc.returncode == 130, "interrupted: a clean exit with status 130"
    else:
        assert proc.returncode == -signal.SIGKILL, "killed outright: the workers notice their parent is gone"
    deadline = time.monotonic() + 10
    while children_alive(workers) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert children_alive(workers) == [], "no orphan worker"
    if sig == signal.SIGTERM:
        assert not ours & shm_segments(PREFIXES), "an interrupted run unlinks its shared memory"
    else:  # killed with its resource tracker: what it left is mapped by no process, so the next start
        # sweeps it away (tests/app/test_takes_crash.py)
        assert not ours & mapped_segments(), "no process holds the killed run's shared memory"
