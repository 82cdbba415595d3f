#!/usr/bin/env python
"""Compare action models on held-out test sets of every source (the "beats the old model" check).

    .venv/bin/python scripts/eval_sources.py --model OLD.onnx --model NEW.onnx \\
        --source sim=sim:stepping+mixed+still-heavy@48 --source still=sim:still@32 --source gait@24 \\
        --source mocap=~/.cache/cavewalk/data/mocap --json out.json

Each source is prepared like the training data (:mod:`pipeline.recognition.prepare`: 30 fps,
captured through the simulated CAVE cameras and our triangulation) but with its own seed
(``--seed``, default 7919; training uses 0), so the routines, people and capture noise are new;
only the original clips are scored (not mirrored, own speed). With ``--direct`` the sequences are
scored as they are, at 30 fps, without the capture (what ``cavewalk evaluate --skeletons`` does).
Every model's outputs are computed once (:func:`evaluation.network_trace`) and the streaming
recogniser's filter and gate replayed (:func:`evaluation.replay`, checked against ``ActionRecognizer`` in
tests/pipeline/recognition/test_evaluation.py), with the recogniser's default settings, with
``--both`` also without the gate, and with each ``--gate-variant NAME:KEY=VALUE,...`` (gate settings
changed from the defaults, e.g. ``before:hold_still_prob=0,late_still_prob=1,jump_air_s=inf``).
Figures from :func:`metrics.evaluate` (``cavewalk evaluate``'s).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from dataclasses import dataclass, replace
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))

from loso_action import summary  # noqa: E402
from train_action import any_source_spec  # noqa: E402

from pipeline.recognition.bout import GateConfig  # noqa: E402
from pipeline.recognition.dataset import LabelledSequence  # noqa: E402
from pipeline.recognition.evaluation import network_trace, replay, step_frames  # noqa: E402
from pipeline.recognition.metrics import ScoredSequence, evaluate, text_report  # noqa: E402
from pipeline.recognition.prepare import SourceSpec, clean_sequences, prepare_corpus  # noqa: E402
from pipeline.recognition.recognizer import RecognizerConfig, open_session  # noqa: E402

DEFAULT_SOURCES = ("sim=sim:stepping+mixed+still-heavy@48", "still=sim:still@32", "gait@24")


@dataclass(frozen=True, slots=True)
class _Item:
    seq: LabelledSequence


def gate_variant(text: str) -> tuple[str, GateConfig]:
    """``NAME:KEY=VALUE,...`` -> (NAME, the default GateConfig with those settings)."""
    name, _, body = text.partition(":")
    if not name or not body:
        raise SystemExit(f"error: --gate-variant wants NAME:KEY=VALUE,..., got {text!r}")
    fields = {f.name: f.type for f in dataclasses.fields(GateConfig)}
    changes: dict[str, object] = {}
    for item in body.split(","):
        key, _, value = item.partition("=")
        if key not in fields:
            raise SystemExit(f"error: unknown gate setting {key!r} (known: {', '.join(fields)})")
        if fields[key] in ("bool", bool):
            if value not in ("true", "false"):
                raise SystemExit(f"error: gate setting {key} wants true or false, got {value!r}")
            changes[key] = value == "true"
        else:
            changes[key] = value if key == "rhythm" else float(value)
    return name, replace(GateConfig(), **changes)  # type: ignore[arg-type]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", action="append", type=Path, required=True)
    ap.add_argument(
        "--source",
        action="append",
        type=any_source_spec,
        help=f"test sources (default {' '.join(DEFAULT_SOURCES)})",
    )
    ap.add_argument("--seed", type=int, default=7919)
    ap.add_argument("--duration", type=float, default=40.0)
    ap.add_argument("--cache", type=Path, default=Path("/tmp/cavewalk-action-cache"))
    ap.add_argument("--both", action="store_true", help="also without the gate")
    ap.add_argument(
        "--direct",
        action="store_true",
        help="score the sequences as they are (30 fps), not captured through the simulated cameras",
    )
    ap.add_argument(
        "--gate-variant",
        action="append",
        default=[],
        help="NAME:KEY=VALUE,... gate settings changed from the defaults (repeat)",
    )
    ap.add_argument("--report", action="store_true", help="print the full text report per source")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()

    def say(msg: str) -> None:
        print(msg, flush=True)

    variants = [gate_variant(v) for v in args.gate_variant]
    specs = args.source or [SourceSpec.parse(s) for s in DEFAULT_SOURCES]
    if args.direct:  # the files' own joints, as `cavewalk evaluate --skeletons` reads them
        seqs = [s for _, s, original in clean_sequences(specs, 32, args.duration, args.seed, say) if original]
    else:
        seqs = [
            it.seq
            for it in prepare_corpus(specs, args.cache, 32, args.duration, args.seed, progress=say)
            if it.original
        ]
    items = [_Item(s) for s in seqs]
    frames = [step_frames(it.seq.joints_m, it.seq.fps) for it in items]
    out: dict[str, dict[str, dict[str, object]]] = {}
    base = RecognizerConfig()
    runs: list[tuple[str, RecognizerConfig]] = [("", base)]
    if args.both:
        runs.append((" (no gate)", replace(base, gate=False)))
    runs += [(f" ({name})", replace(base, gate_config=g)) for name, g in variants]
    for model in args.model:
        session = open_session(model)
        traces = [
            network_trace(session, it.seq.joints_m, it.seq.fps, frames=f)
            for it, f in zip(items, frames, strict=True)
        ]
        for suffix, run_config in runs:
            config = replace(run_config, model_path=model)
            key = f"{model.name}{suffix}"
            out[key] = {}
            for spec in specs:
                scored = [
                    ScoredSequence(
                        it.seq.name, it.seq.source, it.seq.labels, replay(t, config), it.seq.tags,
                        it.seq.fps, it.seq.contacts,
                    )
                    for it, t in zip(items, traces, strict=True)
                    if it.seq.source == spec.name
                ]  # fmt: skip
                ev = evaluate(scored)
                m = summary(ev)
                out[key][spec.name] = m
                say(
                    f"{key:>28} {spec.name:>8}: acc {m['accuracy']} F1 {m['macro_f1']} false {m['false_movement']} "  # noqa: E501
                    f"(starts {m['false_starts']}) detected {m['movement_detected']} "
                    f"start {m['start_median_s']}/{m['start_p95_s']} "
                    f"stop {m['stop_median_s']}/{m['stop_p95_s']} beyond {m['stop_beyond_rhythm_median_s']}/"
                    f"{m['stop_beyond_rhythm_p95_s']} flicker {m['flicker']}"
                )
                if args.report:
                    say(text_report(ev))
    if args.json is not None:
        args.json.write_text(json.dumps(out, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
