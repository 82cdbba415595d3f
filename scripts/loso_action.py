#!/usr/bin/env python
"""Leave-one-source-out evaluation and the evidence ablation (the model card's main table).

    .venv/bin/python scripts/loso_action.py --source sim --source still=DIR --source gait=DIR \\
        --source mocap=DIR --epochs 12 --windows-per-epoch 40000 --json loso.json --markdown loso.md

For each held-out source S: train the network on every other source (features v1: joints only,
and v2: joints + step evidence; same seed and settings), then stream S's original clips (not
mirrored, own speed; captured through the simulated cameras like the training data) through the
recogniser four ways: network alone (EMA + hysteresis), network + gate, network with the evidence
features, both. Figures from the shared metrics module (``cavewalk evaluate``'s). The recogniser's
per-frame work after the model is replayed from the model's batched outputs
(:func:`evaluation.replay`, the streaming recogniser's commands; see test_evaluation.py).
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
import time
from dataclasses import asdict, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from train_action import add_arguments, any_source_spec, check_train_config, train_config  # noqa: E402

from pipeline.recognition.evaluation import network_trace, replay, step_frames, tune_gate  # noqa: E402
from pipeline.recognition.features import FEATURE_CHANNELS, FEATURES_V1, FEATURES_V2, FEATURES_V3  # noqa: E402
from pipeline.recognition.metrics import Evaluation, ScoredSequence, evaluate  # noqa: E402
from pipeline.recognition.prepare import SourceSpec, prepare_corpus, split_items, to_dataset  # noqa: E402
from pipeline.recognition.recognizer import RecognizerConfig, open_session  # noqa: E402
from pipeline.recognition.train import export_onnx, train_model  # noqa: E402

VARIANTS = (
    ("network alone", FEATURES_V1, False),
    ("+ gate", FEATURES_V1, True),
    ("+ features", FEATURES_V2, False),
    ("both", FEATURES_V2, True),
    ("legs + features", FEATURES_V3, False),  # v3: arms and face masked
    ("legs, both", FEATURES_V3, True),
)


def summary(ev: Evaluation) -> dict[str, object]:
    def q(v: float | None) -> float | None:
        return None if v is None else round(v, 3)

    return {
        "frames": ev.frames,
        "accuracy": q(ev.accuracy),
        "macro_f1": q(ev.macro_f1),
        "false_movement": q(ev.overall.false_movement),
        "false_movement_after_bout": q(ev.overall.false_after_bout),
        "false_starts": q(ev.overall.false_starts),
        "still_frames": ev.overall.still_frames,
        "movement_detected": q(ev.overall.movement_detected),
        "moving_frames": ev.overall.moving_frames,
        "start_median_s": q(ev.start.median_s),
        "start_p95_s": q(ev.start.p95_s),
        "start_missed": ev.start.missed,
        "stop_median_s": q(ev.stop.median_s),
        "stop_p95_s": q(ev.stop.p95_s),
        "stop_beyond_rhythm_median_s": q(ev.stop_beyond_rhythm.median_s),
        "stop_beyond_rhythm_p95_s": q(ev.stop_beyond_rhythm.p95_s),
        "stop_missed": ev.stop.missed,
        "flicker": q(ev.flicker),
        "confusion": ev.confusion.tolist(),
        "false_movement_per_tag": {g.name: q(g.false_movement) for g in ev.per_tag if g.still_frames},
        "movement_detected_per_tag": {g.name: q(g.movement_detected) for g in ev.per_tag if g.moving_frames},
    }


def _cell(v: object, pct: bool = False, ms: bool = False) -> str:
    if v is None:
        return "—"
    if pct:
        return f"{100 * float(v):.1f} %"  # type: ignore[arg-type]
    if ms:
        return f"{1000 * float(v):.0f}"  # type: ignore[arg-type]
    return f"{float(v):.3f}"  # type: ignore[arg-type]


def markdown(results: dict[str, dict[str, dict[str, object]]]) -> str:
    head = (
        "| held-out source | variant | frames | accuracy | macro-F1 | false movement | movement detected "
        "| start med / p95 ms | stop med / p95 ms | stop beyond rhythm med / p95 ms |\n"
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
    )
    rows = [head]
    for src, variants in results.items():
        for name, m in variants.items():
            rows.append(
                f"| {src} | {name} | {m['frames']} | {_cell(m['accuracy'])} | {_cell(m['macro_f1'])} "
                f"| {_cell(m['false_movement'], pct=True)} | {_cell(m['movement_detected'], pct=True)} "
                f"| {_cell(m['start_median_s'], ms=True)} / {_cell(m['start_p95_s'], ms=True)} "
                f"| {_cell(m['stop_median_s'], ms=True)} / {_cell(m['stop_p95_s'], ms=True)} "
                f"| {_cell(m['stop_beyond_rhythm_median_s'], ms=True)} / {_cell(m['stop_beyond_rhythm_p95_s'], ms=True)} |"  # noqa: E501
            )
    return "\n".join(rows) + "\n"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_arguments(ap)
    ap.add_argument("--hold-out", action="append", help="sources to hold out (default: each)")
    ap.add_argument(
        "--eval-source",
        action="append",
        type=any_source_spec,
        default=[],
        help="NAME=DIR of labelled NPZ never trained on (real mocap): scored in every fold",
    )
    ap.add_argument("--out-dir", type=Path, default=Path("/tmp/cavewalk-loso"))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--markdown", type=Path, default=None)
    ap.add_argument("--reuse", action="store_true", help="reuse fold models already in --out-dir")
    ap.add_argument(
        "--features",
        action="append",
        choices=list(FEATURE_CHANNELS),
        help="train only these feature versions per fold (default both: the four-way ablation)",
    )
    args = ap.parse_args()
    check_train_config(ap, args, FEATURES_V2)
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    def say(msg: str) -> None:
        print(msg, flush=True)

    specs = args.source or [SourceSpec.parse("sim")]
    sources = [replace(s, warp=s.name in args.warp) for s in specs]
    items = prepare_corpus(sources, args.cache, args.sequences, args.duration, args.seed, progress=say)
    eval_specs = args.eval_source
    eval_only = [
        it
        for it in prepare_corpus(
            eval_specs, args.cache, args.sequences, args.duration, args.seed, progress=say
        )
        if it.original
    ]
    names = sorted({it.seq.source for it in items})
    held = args.hold_out or names
    args.out_dir.mkdir(parents=True, exist_ok=True)
    results: dict[str, dict[str, dict[str, object]]] = {}
    timings: dict[str, float] = {}
    chosen: dict[str, object] = {}
    for src in held:
        train_items = [it for it in items if it.seq.source != src]
        test_items = [it for it in items if it.seq.source == src and it.original] + eval_only
        if not train_items or not test_items:
            say(f"skip {src}: nothing to train on or to test")
            continue
        tr, va = split_items(train_items, 0.1, args.seed)
        train, val = to_dataset(tr), to_dataset(va)
        frames = [step_frames(it.seq.joints_m, it.seq.fps) for it in test_items]
        models = {}
        for feat in args.features or (FEATURES_V1, FEATURES_V2):
            path = args.out_dir / f"fold-{src}-{feat}.onnx"
            if not (args.reuse and path.is_file()):
                t0 = time.monotonic()
                say(f"== fold {src}: {feat} on {len(train.labels)} frames of {sorted(set(train.sources))}")
                cfg = train_config(args, feat)
                model, _ = train_model(train, val, cfg, progress=say)
                export_onnx(model, path, cfg.window, train.fps, features=feat)
                timings[f"{src}/{feat}"] = time.monotonic() - t0
            models[feat] = open_session(path)
        traces = {
            feat: [
                network_trace(s, it.seq.joints_m, it.seq.fps, frames=f)
                for it, f in zip(test_items, frames, strict=True)
            ]
            for feat, s in models.items()
        }
        # the gate's settings: chosen on the training sources' validation clips, never on S
        tune_items = [it for it in va if it.original]
        gates = {}
        for feat, s in models.items():
            tune_traces = [network_trace(s, it.seq.joints_m, it.seq.fps) for it in tune_items]
            gates[feat], _ = tune_gate(tune_traces, [it.seq for it in tune_items], RecognizerConfig())
            chosen[f"{src}/{feat}"] = asdict(gates[feat])
            say(f"fold {src} {feat}: gate chosen on {len(tune_items)} validation clips: {gates[feat]}")
        for name, feat, gate in [v for v in VARIANTS if v[1] in models]:
            config = replace(RecognizerConfig(), gate=gate, gate_config=gates[feat])
            scored = [
                ScoredSequence(
                    it.seq.name,
                    it.seq.source,
                    it.seq.labels,
                    replay(t, config),
                    it.seq.tags,
                    it.seq.fps,
                    it.seq.contacts,
                )
                for it, t in zip(test_items, traces[feat], strict=True)
            ]
            for test_src in sorted({x.source for x in scored}):
                key = src if test_src == src else f"{test_src} (fold without {src})"
                part = [x for x in scored if x.source == test_src]
                results.setdefault(key, {})[name] = summary(evaluate(part))
                m = results[key][name]
                say(
                    f"{key:>12} {name:>14}: acc {m['accuracy']} F1 {m['macro_f1']} false {m['false_movement']} "  # noqa: E501
                    f"detected {m['movement_detected']} start {m['start_median_s']}/{m['start_p95_s']} "
                    f"stop {m['stop_median_s']}/{m['stop_p95_s']} beyond {m['stop_beyond_rhythm_median_s']}/"
                    f"{m['stop_beyond_rhythm_p95_s']}"
                )
    table = markdown(results)
    print(table)
    if args.markdown is not None:
        args.markdown.write_text(table)
    if args.json is not None:
        out = {"results": results, "train_s": timings, "sources": names, "gate_settings": chosen}
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
