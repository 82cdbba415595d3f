"""Benchmarks of the live pipeline: throughput, drops, per-stage and end-to-end latency, CPU, memory.

Each scenario runs the real :class:`Pipeline` (real worker processes, shared memory,
UDP to a receiver on 127.0.0.1), waits until it runs, discards the warm-up, then
measures for ``duration_s``. Used by ``cavewalk bench`` and ``scripts/soak.py``.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import multiprocessing.queues as mpq
import os
import platform
import queue as _queue
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import psutil

from pipeline.emitter.receiver import open_receiver_socket, receive
from pipeline.errors import SourceError
from pipeline.machine import machine_facts
from pipeline.pose.config import PoseConfig
from pipeline.runtime.metrics import percentiles
from pipeline.runtime.pipeline import Pipeline
from pipeline.runtime.status import PipelineStatus
from pipeline.runtime.workers import StopFlag
from pipeline.takes.config import TakesConfig
from pipeline.takes.video import VideoSession

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Scenario:
    """One benchmark run: a name, how to build the pipeline, what to start."""

    name: str
    build: Callable[[], Pipeline]
    source: str
    videos: dict[str, Path] | None = None
    notes: str = ""
    record_videos: TakesConfig | None = None  # while measuring, record every camera's MP4 (a take's)


class ProcessSampler:
    """CPU (percent of one core, summed over the main process and its workers) and memory (RSS, MB)."""

    def __init__(self) -> None:
        self._psutil = psutil
        self._me = psutil.Process(os.getpid())
        self._last: dict[int, float] = {}
        self._t = time.monotonic()
        self.cpu_samples: list[float] = []
        self.rss_samples_mb: list[float] = []
        self.sample()
        self.cpu_samples.clear()

    def _procs(self) -> list[psutil.Process]:
        try:
            return [self._me, *self._me.children(recursive=True)]
        except self._psutil.Error:
            return [self._me]

    def sample(self) -> None:
        now = time.monotonic()
        cpu_total = 0.0
        rss = 0.0
        seen: dict[int, float] = {}
        for p in self._procs():
            try:
                t = p.cpu_times()
                used = t.user + t.system
                rss += p.memory_info().rss
            except self._psutil.Error:
                continue
            seen[p.pid] = used
            cpu_total += used - self._last.get(p.pid, used if p.pid not in self._last else 0.0)
        dt = now - self._t
        if dt < 0.5:  # CPU times tick at 10 ms: a short interval gives no usable percentage
            self.rss_samples_mb.append(rss / 1e6)
            return
        if self._last:
            self.cpu_samples.append(100.0 * cpu_total / dt)
        self._last, self._t = seen, now
        self.rss_samples_mb.append(rss / 1e6)


def receiver_process(port_q: mpq.Queue[int], go: StopFlag, stop: StopFlag,
                     out_q: mpq.Queue[dict[str, Any]]) -> None:
    """The workstation end of a benchmark, in its own process (no GIL shared with the pipeline):
    binds a port, discards what came before ``go``, receives until ``stop``, returns the summary."""
    sock = open_receiver_socket(0, "127.0.0.1")
    port_q.put(sock.getsockname()[1])
    parent = mp.parent_process()
    while not go.wait(0.25):
        if parent is not None and not parent.is_alive():
            return
    sock.setblocking(False)
    while True:  # what arrived during the warm-up is not measured
        try:
            sock.recv(65535)
        except (BlockingIOError, _queue.Empty):
            break
    sock.setblocking(True)
    stats = receive(sock, should_stop=lambda: stop.is_set() or (parent is not None and not parent.is_alive()))
    sock.close()
    out_q.put(stats.summary())


def run_scenario(scenario: Scenario, duration_s: float, warmup_timeout_s: float = 90.0,
                 warmup_s: float = 2.0, progress: Callable[[str], None] = log.info) -> dict[str, Any]:
    """Run one scenario and return its figures (see the module docstring)."""
    ctx = mp.get_context("forkserver")
    port_q, out_q, go, stop_rx = ctx.Queue(), ctx.Queue(), ctx.Event(), ctx.Event()
    rx = ctx.Process(target=receiver_process, args=(port_q, go, stop_rx, out_q), daemon=True)
    rx.start()
    port = int(port_q.get(timeout=60))
    pipeline = scenario.build()
    rx_summary: dict[str, Any] | None = None
    videos: VideoSession | None = None
    video_dir: tempfile.TemporaryDirectory[str] | None = None
    video_stats: dict[str, Any] | None = None
    try:
        pipeline.set_workstations([("127.0.0.1", port)])
        pipeline.start(scenario.source, scenario.videos)  # type: ignore[arg-type]
        _warm_up(pipeline, scenario.name, warmup_timeout_s, warmup_s, progress)
        go.set()
        sampler = ProcessSampler()
        start = time.monotonic()
        s0 = pipeline.status()
        if scenario.record_videos is not None:
            video_dir = tempfile.TemporaryDirectory(prefix="cavewalk-bench-videos-")
            videos = VideoSession(pipeline.video_controls(), Path(video_dir.name), scenario.record_videos)
            videos.start(start, duration_s)
        _measure(pipeline, scenario.name, sampler, start, duration_s, s0, progress)
        elapsed = time.monotonic() - start
        s1 = pipeline.status()
        samples = pipeline.latency_samples()
        sampler.sample()
        if videos is not None:
            video_stats = _video_summary(videos.stop(), Path(video_dir.name), elapsed)  # type: ignore[union-attr]
    finally:
        if video_dir is not None:
            video_dir.cleanup()
        go.set()
        stop_rx.set()
        pipeline.close()
        try:
            rx_summary = out_q.get(timeout=10)
        except Exception:  # the receiver died: the figures go on without it
            log.warning("the benchmark's receiver gave no summary")
        rx.join(timeout=5)
        if rx.is_alive():
            rx.kill()
    return _figures(scenario, elapsed, s0, s1, samples, sampler, rx_summary, video_stats)


def _warm_up(pipeline: Pipeline, name: str, timeout_s: float, warmup_s: float,
             progress: Callable[[str], None]) -> None:
    """Wait for the first results, run ``warmup_s`` more, then start the figures afresh."""
    t0 = time.monotonic()
    while pipeline.status().processed < 3:
        if time.monotonic() - t0 > timeout_s:
            raise SourceError(f"{name}: no results after {timeout_s:.0f} s "
                              f"({pipeline.status().last_error or 'no error reported'})")
        time.sleep(0.2)
    progress(f"[{name}] running after {time.monotonic() - t0:.1f} s; warming up {warmup_s:.0f} s")
    time.sleep(warmup_s)
    pipeline.reset_metrics()


def _measure(pipeline: Pipeline, name: str, sampler: ProcessSampler, start: float, duration_s: float,
             s0: PipelineStatus, progress: Callable[[str], None]) -> None:
    """Sample CPU and memory and report progress once a second for ``duration_s``."""
    next_report = start + 1.0
    while (now := time.monotonic()) - start < duration_s:
        time.sleep(min(0.25, max(0.0, next_report - now)))
        if time.monotonic() >= next_report:
            sampler.sample()
            st = pipeline.status()
            e2e = st.latency_ms["end_to_end"]
            progress(f"[{name}] {time.monotonic() - start:5.1f}/{duration_s:.0f} s  "
                     f"{st.fps:5.1f} fps  processed {st.processed - s0.processed}  dropped "
                     f"{st.dropped - s0.dropped}  e2e p95 {e2e['p95']:.1f} ms  "
                     f"cpu {sampler.cpu_samples[-1] if sampler.cpu_samples else 0:.0f} %")
            next_report += 1.0


def _figures(scenario: Scenario, elapsed: float, s0: PipelineStatus, s1: PipelineStatus,
             samples: dict[str, list[float]], sampler: ProcessSampler, rx_summary: dict[str, Any] | None,
             video_stats: dict[str, Any] | None) -> dict[str, Any]:
    processed = s1.processed - s0.processed
    dropped = s1.dropped - s0.dropped
    return {
        "source": scenario.source,
        "notes": scenario.notes,
        "duration_s": round(elapsed, 2),
        "processed_frames": processed,
        "processed_fps": round(processed / elapsed, 2) if elapsed > 0 else 0.0,
        "dropped_frames": dropped,
        "dropped_fraction": round(dropped / (processed + dropped), 4) if processed + dropped else 0.0,
        "latency_ms": {stage: {k: round(v, 3) for k, v in percentiles(vals).items()}
                       for stage, vals in samples.items()},
        "latency_samples": {stage: len(vals) for stage, vals in samples.items()},
        "cpu_percent": _summary(sampler.cpu_samples),
        "rss_mb": _summary(sampler.rss_samples_mb),
        "cameras": [c.to_json() for c in s1.cameras],
        "receiver": rx_summary,
        "videos": video_stats,
    }


def _video_summary(per_camera: dict[str, dict[str, Any]], folder: Path, elapsed_s: float) -> dict[str, Any]:
    """Frames written and dropped per camera while measuring, the rate written and the bytes."""
    written = sum(int(c["written"]) for c in per_camera.values())
    dropped = sum(int(c["dropped"]) for c in per_camera.values())
    size = sum(p.stat().st_size for p in folder.rglob("*.mp4"))
    return {"cameras": per_camera, "written_frames": written, "dropped_frames": dropped,
            "written_fps_per_camera": round(written / elapsed_s / max(1, len(per_camera)), 2)
            if elapsed_s > 0 else 0.0, "megabytes": round(size / 1e6, 2)}


def _summary(values: list[float]) -> dict[str, float]:
    if not values:
        return {"mean": float("nan"), "max": float("nan")}
    arr = np.asarray(values)
    return {"mean": round(float(arr.mean()), 1), "max": round(float(arr.max()), 1)}


def machine_info(pose: PoseConfig | None = None, model_path: Path | None = None) -> dict[str, Any]:
    """The machine a benchmark ran on: the CPU (model, AVX2/AVX-512/VNNI/AMX, cores), the load,
    onnxruntime's version and, for the pose stage of ``pose``, the execution provider it runs on
    and the model files (see :func:`pipeline.machine.machine_facts`)."""
    facts = machine_facts()
    out: dict[str, Any] = {
        "cpus": os.cpu_count(),
        "load_avg": [round(v, 2) for v in os.getloadavg()],
        "memory_gb": round(psutil.virtual_memory().total / 1e9, 1),
        "python": platform.python_version(),
        "platform": platform.platform(),
        "cpu": facts.as_dict(),
        "summary": facts.summary(),
        "onnxruntime": facts.onnxruntime,
    }
    if pose is not None and facts.onnxruntime is not None:
        from pipeline.pose.detector import session_providers

        out["execution_provider"] = session_providers(pose)[0]
        out["pose"] = {"precision": pose.precision, "crop_model": pose.crop_model, "roi": pose.roi,
                       "roi_long_side": pose.roi_long_side, "input_long_side": pose.input_long_side,
                       "threads": pose.threads, "parallel": pose.parallel,
                       "model": str(model_path) if model_path is not None else None,
                       "crop_model_file": (str(pose.crop_model_file(model_path))
                                           if model_path is not None and pose.crop_model_file(model_path)
                                           else None)}
    return out
