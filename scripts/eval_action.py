#!/usr/bin/env python
"""Evaluate the action recogniser on simulated routines the training never saw.

    .venv/bin/python scripts/eval_action.py                      # the committed model, default settings
    .venv/bin/python scripts/eval_action.py --tune               # pick EMA / dwell on a tuning set first

The test set uses its own seed (default 7919; training uses 0..) and its own script mix:
random routines with longer and shorter segments, still segments full of gestures, weight
shifts and turning on the spot, and bodies drawn at the extremes of the simulator's height
range (1.50-1.53 m and 1.92-1.95 m) besides the whole range. Every routine is captured like
the training data (2D noise through triangulation, dropped joints, gaps) and fed frame by frame
to the streaming :class:`ActionRecognizer` (onnxruntime), exactly as at run time.

Prints the frame accuracy and macro-F1 (excluding 300 ms after each true transition), the
confusion matrix, start/stop latency distributions, false movement while still, the yaw error
and the speed error; ``--json`` writes them.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict, dataclass, replace
from itertools import product
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from pipeline.recognition.metrics import (  # noqa: E402
    angle_error_deg,
    confusion,
    latencies,
    macro_f1,
    text_confusion,
    text_histogram,
    transition_mask,
)
from pipeline.recognition.recognizer import (  # noqa: E402
    ActionRecognizer,
    CommandFilter,
    RecognizerConfig,
    classify_windows,
    open_session,
    recognize_sequence,
)
from pipeline.recognition.train import LABEL_INDEX, NoiseConfig, capture  # noqa: E402
from pipeline.skeleton import ACTIONS  # noqa: E402

FPS = 30.0


@dataclass(frozen=True, slots=True)
class Routine:
    name: str
    clean: np.ndarray  # (T, 17, 3)
    measured: np.ndarray  # (T, 17, 3) with noise and NaN
    truth: np.ndarray  # (T,) int
    yaw_deg: np.ndarray
    speed_mps: np.ndarray
    turning: np.ndarray  # (T,) bool: inside a turn-on-the-spot segment
    gesturing: np.ndarray  # (T,) bool: inside a still segment with scripted gestures


def _still_heavy_script(rng: np.random.Generator, duration_s: float):  # type: ignore[no-untyped-def]
    """Still segments full of gestures and turns, with short bursts of stepping in between."""
    from pipeline.sim.script import GESTURES, MotionScript, Segment

    segs: list[Segment] = []
    total = 0.0
    while total < duration_s:
        kind = rng.choice(["gestures", "turn", "plain", "move"], p=[0.35, 0.25, 0.15, 0.25])
        dur = float(rng.uniform(2.0, 6.0))
        if kind == "gestures":
            g = tuple(str(x) for x in rng.choice(GESTURES, size=int(rng.integers(1, 3)), replace=False))
            segs.append(Segment("still", dur, gestures=g))
        elif kind == "turn":
            segs.append(Segment("turn", dur, turn_deg=float(rng.choice([-1, 1]) * rng.uniform(30, 180))))
        elif kind == "plain":
            segs.append(Segment("still", dur))
        else:
            segs.append(Segment(str(rng.choice(["forward", "left", "right"])), dur))
        total += dur
    return MotionScript(tuple(segs), start_yaw_deg=float(rng.uniform(-180, 180)))


def build_test_set(seed: int, count: int, duration_s: float, noise: NoiseConfig) -> list[Routine]:
    from pipeline.sim.body import sample_body
    from pipeline.sim.motion import simulate_user
    from pipeline.sim.script import random_script

    rng = np.random.default_rng(seed)
    routines = []
    for i in range(count):
        kind = i % 4
        if kind == 0:
            body, tag = sample_body(rng, (1.50, 1.53)), "short"
        elif kind == 1:
            body, tag = sample_body(rng, (1.92, 1.95)), "tall"
        else:
            body, tag = sample_body(rng), "any"
        start = tuple(rng.uniform(-0.6, 0.6, 2))
        if kind == 3:
            script = _still_heavy_script(rng, duration_s)
            tag += "/still-heavy"
        else:
            seg = (0.6, 4.0) if kind == 2 else (1.5, 8.0)
            script = random_script(rng, duration_s, segment_s=seg, start_xy_m=start)  # type: ignore[arg-type]
        motion = simulate_user(script, body, FPS, seed=int(rng.integers(2**31)))
        seg_end = np.cumsum([s.duration_s for s in script.segments])
        k = np.minimum(
            np.searchsorted(seg_end, np.arange(len(motion)) / FPS + 1e-9, side="right"),
            len(script.segments) - 1,
        )
        turning = np.array([script.segments[j].action == "turn" for j in k])
        gesturing = np.array([bool(script.segments[j].gestures) for j in k])
        routines.append(
            Routine(
                name=f"{i:03d} {tag} h={body.height_m:.2f}",
                clean=motion.joints_m,
                measured=capture(motion.joints_m, rng, noise, FPS),
                truth=np.array([LABEL_INDEX[x] for x in motion.labels]),
                yaw_deg=motion.yaw_deg,
                speed_mps=motion.speed_mps,
                turning=turning,
                gesturing=gesturing,
            )
        )
    return routines


def raw_outputs(session: object, routine: Routine, window: int) -> np.ndarray:
    """The model's per-frame outputs on the streaming windows (for tuning the filter quickly)."""
    j = routine.measured
    idx = np.maximum(np.arange(len(j))[:, None] - np.arange(window - 1, -1, -1)[None, :], 0)
    return classify_windows(session, j[idx], FPS)


def filtered(raw: np.ndarray, ema_alpha: float, dwell: float, switch: float, stop: float) -> np.ndarray:
    f = CommandFilter(ema_alpha, dwell, switch, stop)
    return np.array([f.update(p, i / FPS) for i, p in enumerate(raw)])


def score(routines: list[Routine], preds: list[np.ndarray], exclude_s: float) -> dict[str, object]:
    conf = np.zeros((4, 4), dtype=np.int64)
    starts, stops = [], []
    still_frames = still_moving = turn_frames = turn_moving = gest_frames = gest_moving = 0
    true_changes = pred_changes = 0
    for r, p in zip(routines, preds, strict=True):
        keep = transition_mask(r.truth, FPS, exclude_s)
        conf += confusion(r.truth[keep], p[keep])
        lat = latencies(r.truth, p, FPS)
        starts.append(lat.start_s)
        stops.append(lat.stop_s)
        true_changes += int(np.sum(r.truth[1:] != r.truth[:-1]))
        pred_changes += int(np.sum(p[1:] != p[:-1]))
        still = keep & (r.truth == 0)
        still_frames += int(still.sum())
        still_moving += int((still & (p != 0)).sum())
        turn_frames += int((still & r.turning).sum())
        turn_moving += int((still & r.turning & (p != 0)).sum())
        gest_frames += int((still & r.gesturing).sum())
        gest_moving += int((still & r.gesturing & (p != 0)).sum())
    s, e = np.concatenate(starts), np.concatenate(stops)

    def pct(v: np.ndarray, q: float) -> float:
        # a never-detected transition counts as infinitely late
        return float(np.percentile(np.where(np.isfinite(v), v, np.inf), q)) if v.size else float("nan")

    return {
        "frames": int(conf.sum()),
        "accuracy": float(np.trace(conf) / conf.sum()),
        "macro_f1": macro_f1(conf),
        "confusion": conf.tolist(),
        "start_latency_s": {
            "n": int(s.size),
            "median": pct(s, 50),
            "p95": pct(s, 95),
            "missed": int(np.sum(~np.isfinite(s))),
        },
        "stop_latency_s": {
            "n": int(e.size),
            "median": pct(e, 50),
            "p95": pct(e, 95),
            "missed": int(np.sum(~np.isfinite(e))),
        },
        "false_movement_still": still_moving / max(still_frames, 1),
        "false_movement_turning": turn_moving / max(turn_frames, 1),
        "false_movement_gesturing": gest_moving / max(gest_frames, 1),
        "still_frames": still_frames,
        "command_changes_per_true_change": pred_changes / max(true_changes, 1),
        "_starts": s,
        "_stops": e,
    }


def tune(
    routines: list[Routine], raws: list[np.ndarray], exclude_s: float
) -> tuple[float, float, float, float]:
    """Grid search of (ema_alpha, min_dwell_s, switch_prob, stop_dwell_s) on a tuning set: among the
    settings that meet the latency and false-movement targets, the best accuracy with the least flicker."""
    best: tuple[float, tuple[float, float, float, float]] | None = None
    grid = product([0.5, 0.6, 0.75], [0.0, 0.05, 0.1, 0.15], [0.5, 0.6, 0.7], [0.0])
    for a, d, sp, st in grid:
        m = score(routines, [filtered(r, a, d, sp, st) for r in raws], exclude_s)
        start: dict[str, float] = m["start_latency_s"]  # type: ignore[assignment]
        stop: dict[str, float] = m["stop_latency_s"]  # type: ignore[assignment]
        changes = float(m["command_changes_per_true_change"])  # type: ignore[arg-type]
        ok = (
            start["median"] <= 0.3
            and stop["median"] <= 0.3
            and start["p95"] <= 0.5
            and stop["p95"] <= 0.5
            and float(m["false_movement_still"]) < 0.01  # type: ignore[arg-type]
        )
        acc = (float(m["accuracy"]) + float(m["macro_f1"])) / 2  # type: ignore[arg-type]
        key = acc - 0.02 * (changes - 1.0) + (1.0 if ok else 0.0)
        print(
            f"  alpha {a:.2f} dwell {d:.2f} switch {sp:.1f} stop-dwell {st:.2f}: acc {m['accuracy']:.4f} "
            f"F1 {m['macro_f1']:.4f} start {start['median']:.3f}/{start['p95']:.3f} "
            f"stop {stop['median']:.3f}/{stop['p95']:.3f} false {m['false_movement_still']:.4f} "
            f"changes/true {changes:.2f}{'  ok' if ok else ''}",
            flush=True,
        )
        if best is None or key > best[0]:
            best = (key, (a, d, sp, st))
    if best is None:
        raise RuntimeError("empty grid")
    return best[1]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", type=Path, default=ROOT / "pipeline" / "recognition" / "action.onnx")
    ap.add_argument("--seed", type=int, default=7919)
    ap.add_argument("--routines", type=int, default=48)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--exclude", type=float, default=0.3, help="seconds after each true transition left out")
    ap.add_argument(
        "--tune", action="store_true", help="grid-search the filter on a separate tuning set first"
    )
    ap.add_argument("--ema-alpha", type=float, default=None)
    ap.add_argument("--min-dwell", type=float, default=None)
    ap.add_argument("--switch-prob", type=float, default=None)
    ap.add_argument("--stop-dwell", type=float, default=None)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--no-gate", action="store_true", help="the network's EMA + hysteresis alone")
    args = ap.parse_args()

    config = RecognizerConfig(model_path=args.model, gate=not args.no_gate)
    session = open_session(args.model)
    noise = NoiseConfig()
    if args.tune:
        print("tuning set (seed 104729):", flush=True)
        tuning = build_test_set(104729, 24, args.duration, noise)
        raws = [raw_outputs(session, r, 32) for r in tuning]
        a, d, sp, st = tune(tuning, raws, args.exclude)
        config = replace(config, ema_alpha=a, min_dwell_s=d, switch_prob=sp, stop_dwell_s=st)
        print(f"chosen: ema_alpha {a}, min_dwell_s {d}, switch_prob {sp}, stop_dwell_s {st}")
    overrides = {
        k: v
        for k, v in (
            ("ema_alpha", args.ema_alpha),
            ("min_dwell_s", args.min_dwell),
            ("switch_prob", args.switch_prob),
            ("stop_dwell_s", args.stop_dwell),
        )
        if v is not None
    }
    config = replace(config, **overrides)
    t0 = time.monotonic()
    routines = build_test_set(args.seed, args.routines, args.duration, noise)
    print(
        f"test set: {len(routines)} routines x {args.duration:g} s, seed {args.seed} "
        f"({time.monotonic() - t0:.0f} s to simulate)",
        flush=True,
    )
    rec = ActionRecognizer(session, config)
    preds, yaw_err, speed_err, speed_rel = [], [], [], []
    t0 = time.monotonic()
    for r in routines:
        est = recognize_sequence(rec, r.measured, FPS)
        p = np.array([ACTIONS.index(e.label) for e in est])
        preds.append(p)
        yaw = np.array([e.yaw_deg for e in est])
        yaw_err.append(angle_error_deg(yaw, r.yaw_deg)[int(FPS) :])
        both = (p == r.truth) & (r.truth != 0) & transition_mask(r.truth, FPS, 2.5)
        sp = np.array([e.speed_mps for e in est])
        speed_err.append(np.abs(sp - r.speed_mps)[both])
        speed_rel.append((np.abs(sp - r.speed_mps) / np.maximum(r.speed_mps, 1e-6))[both])
    run_s = time.monotonic() - t0
    m = score(routines, preds, args.exclude)
    ye, se, sr = np.concatenate(yaw_err), np.concatenate(speed_err), np.concatenate(speed_rel)
    n_frames = sum(len(r.truth) for r in routines)
    print(
        f"\nsettings: ema_alpha {config.ema_alpha}, min_dwell_s {config.min_dwell_s}, "
        f"switch_prob {config.switch_prob}, stop_dwell_s {config.stop_dwell_s}"
    )
    print(
        f"streamed {n_frames} frames in {run_s:.1f} s "
        f"({1000 * run_s / n_frames:.3f} ms per frame, all included)"
    )
    print(
        f"frame accuracy {m['accuracy']:.4f}, macro-F1 {m['macro_f1']:.4f} "
        f"({m['frames']} frames, {args.exclude * 1000:.0f} ms after each true transition excluded)"
    )
    print(text_confusion(np.asarray(m["confusion"])))
    for name in ("start", "stop"):
        lat: dict[str, float] = m[f"{name}_latency_s"]  # type: ignore[assignment]
        print(
            f"{name} latency: n={lat['n']:.0f} median {lat['median'] * 1000:.0f} ms, "
            f"p95 {lat['p95'] * 1000:.0f} ms, missed {lat['missed']:.0f}"
        )  # type: ignore[index]
        print(text_histogram(m[f"_{name}s"], [0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0]))  # type: ignore[arg-type]
    print(
        f"false movement while still: {m['false_movement_still']:.4%} of {m['still_frames']} frames "
        f"(turning on the spot {m['false_movement_turning']:.4%}, scripted gestures "
        f"{m['false_movement_gesturing']:.4%})"
    )
    print(f"command changes per true change: {m['command_changes_per_true_change']:.2f} (1.00 = no flicker)")
    print(f"yaw error: median {np.median(ye):.2f} deg, p95 {np.percentile(ye, 95):.2f} deg")
    print(
        f"speed error while moving (correct class, steady): median {np.median(se):.3f} m/s "
        f"({np.median(sr):.1%}), p95 {np.percentile(se, 95):.3f} m/s"
    )
    if args.json is not None:
        out = {k: v for k, v in m.items() if not k.startswith("_")}
        out.update(
            settings=asdict(config) | {"model_path": str(config.model_path)},
            yaw_error_deg={"median": float(np.median(ye)), "p95": float(np.percentile(ye, 95))},
            speed_error_mps={"median": float(np.median(se)), "p95": float(np.percentile(se, 95))},
            ms_per_frame=1000 * run_s / n_frames,
            seed=args.seed,
            routines=len(routines),
            duration_s=args.duration,
        )
        args.json.write_text(json.dumps(out, indent=2, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
