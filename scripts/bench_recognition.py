#!/usr/bin/env python
"""Benchmark of the streaming recogniser: time per ``update()`` (step evidence + features + ONNX
model + EMA + gate + yaw + speed) on a simulated routine, and of the bare model call and the step
tracker.

    .venv/bin/python scripts/bench_recognition.py [--frames 3000] [--threads 1] [--calls 1000] [--no-gate]
        [--json out.json]

Wall time (perf_counter) and this thread's CPU time (thread_time) are both reported: on a shared,
loaded machine the wall time includes waiting for a core, the CPU time does not. ``update_without_model``
is each ``update()`` less its own model call, timed inside it: on a shared machine the model call's
time swings between runs (0.5 to 0.9 ms on one host) more than the rest of the work does, so compare
code changes outside the model on it. The JSON names the machine (:func:`pipeline.machine.machine_facts`:
the CPU, its AVX2 / AVX-512 / VNNI / AMX, cores, onnxruntime) and prints it.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.machine import machine_facts  # noqa: E402
from pipeline.recognition.features import (  # noqa: E402
    EVIDENCE_CHANNELS,
    WITH_EVIDENCE,
    model_input,
    window_features,
)
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig, open_session  # noqa: E402
from pipeline.recognition.steps import StepTracker  # noqa: E402
from pipeline.recognition.train import NoiseConfig, capture  # noqa: E402


class _TimedSession:
    """An onnxruntime session that keeps the time of its last ``run`` (the model's share of an
    ``update()``, measured inside the same call: the model's time varies between runs on a shared
    machine more than the rest of the work does)."""

    def __init__(self, session: Any) -> None:
        self._session = session
        self.last_s = 0.0

    def run(self, *args: Any, **kwargs: Any) -> Any:
        t0 = time.perf_counter()
        out = self._session.run(*args, **kwargs)
        self.last_s = time.perf_counter() - t0
        return out

    def __getattr__(self, name: str) -> Any:
        return getattr(self._session, name)


def routine(frames: int, fps: float) -> np.ndarray:
    """The bench's skeletons (T, 17, 3): a random simulated routine (seed 1) captured with noise, at
    least ``frames`` long and at least the warm-up's 100 frames and a window (the same routine for
    100 frames or more)."""
    from pipeline.sim.body import sample_body
    from pipeline.sim.motion import simulate_user
    from pipeline.sim.script import random_script

    rng = np.random.default_rng(1)
    script = random_script(rng, max(frames / fps + 1.0, 100 / fps + 2.0))
    motion = simulate_user(script, sample_body(rng), fps, seed=1)
    return capture(motion.joints_m, rng, NoiseConfig(), fps)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", type=Path, default=ROOT / "pipeline" / "recognition" / "action.onnx")
    ap.add_argument("--frames", type=int, default=3000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--calls", type=int, default=1000, help="bare model and feature calls timed")
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--no-gate", action="store_true", help="the network's EMA + hysteresis alone")
    args = ap.parse_args()
    if min(args.frames, args.threads, args.calls) < 1:
        got = f"{args.frames}, {args.threads}, {args.calls}"
        ap.error(f"--frames, --threads and --calls must be at least 1, got {got}")
    if not args.model.is_file():
        ap.error(f"no model file {args.model}")

    fps = 30.0
    captured = routine(args.frames, fps)
    joints = captured[: args.frames]

    config = RecognizerConfig(model_path=args.model, threads=args.threads, gate=not args.no_gate)
    timed = _TimedSession(open_session(config.model_path, config.threads))
    rec = ActionRecognizer(timed, config)
    for i in range(100):  # warm-up
        rec.update(captured[i], i / fps)
    rec.reset()
    times = np.empty(len(joints))
    cpu = np.empty(len(joints))
    rest = np.empty(len(joints))
    for i, frame in enumerate(joints):
        timed.last_s = 0.0
        c0, t0 = time.thread_time(), time.perf_counter()
        rec.update(frame, i / fps)
        times[i] = time.perf_counter() - t0
        cpu[i] = time.thread_time() - c0
        rest[i] = times[i] - timed.last_s

    window = captured[: rec.info.window]
    feats = window_features(window, fps)
    ev = np.zeros((rec.info.window, EVIDENCE_CHANNELS), np.float32)
    x = model_input(feats, ev if rec.info.features in WITH_EVIDENCE else None, rec.info.features)[None]
    session, name = rec.session, rec.info.input_name
    model_t = np.empty(args.calls)
    feat_t = np.empty(args.calls)
    for i in range(args.calls):
        t0 = time.perf_counter()
        session.run(None, {name: x})
        model_t[i] = time.perf_counter() - t0
        t0 = time.perf_counter()
        window_features(window, fps)
        feat_t[i] = time.perf_counter() - t0
    tracker = StepTracker()
    step_t = np.empty(len(joints))
    for i, frame in enumerate(joints):
        t0 = time.perf_counter()
        tracker.update(frame, i / fps)
        step_t[i] = time.perf_counter() - t0

    def stats(v: np.ndarray) -> dict[str, float]:
        ms = v * 1000
        return {q: float(np.percentile(ms, p)) for q, p in (("median", 50), ("p95", 95), ("p99", 99))} | {
            "mean": float(ms.mean()),
            "max": float(ms.max()),
        }

    machine = machine_facts()
    out = {
        "update_ms": stats(times),
        "update_cpu_ms": stats(cpu),
        "update_without_model_ms": stats(rest),
        "model_ms": stats(model_t),
        "features_ms": stats(feat_t),
        "step_evidence_ms": stats(step_t),
        "gate": config.gate,
        "features": rec.info.features,
        "load_avg": list(os.getloadavg()),
        "frames": len(joints),
        "threads": args.threads,
        "cpu": machine.summary(),
        "machine": machine.as_dict(),
        "model_bytes": args.model.stat().st_size,
    }
    for key in (
        "update_ms",
        "update_cpu_ms",
        "update_without_model_ms",
        "model_ms",
        "features_ms",
        "step_evidence_ms",
    ):
        s = out[key]
        print(
            f"{key[:-3]:>20}: median {s['median']:.3f} ms, p95 {s['p95']:.3f} ms, "  # type: ignore[index]
            f"p99 {s['p99']:.3f} ms, mean {s['mean']:.3f} ms, max {s['max']:.3f} ms"
        )  # type: ignore[index]
    print(f"{'machine':>20}: {out['cpu']}")
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
