#!/usr/bin/env python
"""Benchmark of the streaming recogniser: time per ``update()`` (step evidence + features + ONNX
model + EMA + gate + yaw + speed) on a simulated routine, and of the bare model call and the step
tracker.

    .venv/bin/python scripts/bench_recognition.py [--frames 3000] [--threads 1] [--no-gate] [--json out.json]

Wall time (perf_counter) and this thread's CPU time (thread_time) are both reported: on a shared,
loaded machine the wall time includes waiting for a core, the CPU time does not.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.recognition.features import (  # noqa: E402
    EVIDENCE_CHANNELS,
    WITH_EVIDENCE,
    model_input,
    window_features,
)
from pipeline.recognition.recognizer import ActionRecognizer, RecognizerConfig  # noqa: E402
from pipeline.recognition.steps import StepTracker  # noqa: E402
from pipeline.recognition.train import NoiseConfig, capture  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", type=Path, default=ROOT / "pipeline" / "recognition" / "action.onnx")
    ap.add_argument("--frames", type=int, default=3000)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--no-gate", action="store_true", help="the network's EMA + hysteresis alone")
    args = ap.parse_args()

    from pipeline.sim.body import sample_body
    from pipeline.sim.motion import simulate_user
    from pipeline.sim.script import random_script

    rng = np.random.default_rng(1)
    fps = 30.0
    script = random_script(rng, args.frames / fps + 1.0)
    motion = simulate_user(script, sample_body(rng), fps, seed=1)
    joints = capture(motion.joints_m, rng, NoiseConfig(), fps)[: args.frames]

    config = RecognizerConfig(model_path=args.model, threads=args.threads, gate=not args.no_gate)
    rec = ActionRecognizer.from_config(config)
    for i in range(100):  # warm-up
        rec.update(joints[i], i / fps)
    rec.reset()
    times = np.empty(len(joints))
    cpu = np.empty(len(joints))
    for i, frame in enumerate(joints):
        c0, t0 = time.thread_time(), time.perf_counter()
        rec.update(frame, i / fps)
        times[i] = time.perf_counter() - t0
        cpu[i] = time.thread_time() - c0

    window = joints[: rec.info.window]
    feats = window_features(window, fps)
    ev = np.zeros((rec.info.window, EVIDENCE_CHANNELS), np.float32)
    x = model_input(feats, ev if rec.info.features in WITH_EVIDENCE else None, rec.info.features)[None]
    session, name = rec.session, rec.info.input_name
    model_t = np.empty(1000)
    feat_t = np.empty(1000)
    for i in range(1000):
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

    out = {
        "update_ms": stats(times),
        "update_cpu_ms": stats(cpu),
        "model_ms": stats(model_t),
        "features_ms": stats(feat_t),
        "step_evidence_ms": stats(step_t),
        "gate": config.gate,
        "features": rec.info.features,
        "load_avg": list(os.getloadavg()),
        "frames": len(joints),
        "threads": args.threads,
        "cpu": platform.processor() or platform.machine(),
        "model_bytes": args.model.stat().st_size,
    }
    for key in ("update_ms", "update_cpu_ms", "model_ms", "features_ms", "step_evidence_ms"):
        s = out[key]
        print(
            f"{key[:-3]:>14}: median {s['median']:.3f} ms, p95 {s['p95']:.3f} ms, "  # type: ignore[index]
            f"p99 {s['p99']:.3f} ms, mean {s['mean']:.3f} ms, max {s['max']:.3f} ms"
        )  # type: ignore[index]
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
