#!/usr/bin/env python
"""Train the skeleton SlowFast action model on labelled sequences from several sources; export ONNX.

    .venv/bin/python scripts/train_action.py                                  # our simulator only
    .venv/bin/python scripts/train_action.py --source sim --source gait --source blind@60 --source mocap=DIR
    .venv/bin/python scripts/train_action.py --sequences 40 --epochs 2 --out /tmp/a.onnx   # a quick try

Sources: ``sim`` (our simulator's random routines, ``--sequences`` of ``--duration`` s), ``gait``,
``blind``, ``blind2`` and ``blind3`` (the second to fifth motion models, other seeds than their
held-out sets; the sixth to ninth, ``pipeline.sim.blind4`` to ``blind7``, are never trained on)
or ``NAME=DIR`` (every labelled SPEC NPZ under DIR: the still-behaviour library, converted real
motion capture...), prepared by :mod:`pipeline.recognition.prepare` (30 fps, mirrored, ``--warp
NAME`` sources also at 0.85x / 1.15x, captured through the simulated CAVE cameras and our
triangulation, step evidence from the run-time tracker; cached in --cache).
Windows are drawn with each source weighing (its frames) ** 0.5. Needs the ``train`` extra
(torch, onnx). Deterministic for a seed. ``--members N`` trains N networks, the k-th with seed
``--seed`` + k for its data draw and its weights, and writes their ensemble (the mean of their
logits, :class:`pipeline.recognition.model.SlowFastEnsemble`) as one ONNX file.
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

import numpy as np  # noqa: E402

from pipeline.errors import InputError  # noqa: E402
from pipeline.mocap.sources import evaluation_only  # noqa: E402
from pipeline.recognition.features import FEATURE_CHANNELS, FEATURES_V2  # noqa: E402
from pipeline.recognition.prepare import SourceSpec, prepare_corpus, split_items, to_dataset  # noqa: E402
from pipeline.recognition.steps import StepConfig  # noqa: E402
from pipeline.recognition.train import DataConfig, TrainConfig, export_onnx, train_model  # noqa: E402

_D, _T = DataConfig(), TrainConfig()


def share(text: str) -> float:
    """An argparse type: a share from 0 to 1 (argparse turns the ValueError into one error line)."""
    value = float(text)
    if not 0.0 <= value <= 1.0:
        raise ValueError(text)
    return value


def any_source_spec(text: str) -> SourceSpec:
    """An argparse type: a source to score (a bad one is one argparse error line, exit 2)."""
    try:
        return SourceSpec.parse(text)
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from exc


def source_spec(text: str) -> SourceSpec:
    """An argparse type: a ``--source`` to train on; a folder that ``cavewalk data sources`` wrote
    for evaluation only is refused like a bad one."""
    spec = any_source_spec(text)
    held = evaluation_only(spec.folder) if spec.folder is not None else None
    if held is not None:  # sources.json says it is held out: evaluation only
        raise argparse.ArgumentTypeError(
            f"{spec.folder} is the held-out source {held!r} (sources.json: use eval): it is never trained on"
        )
    return spec


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--cache", type=Path, default=Path("/tmp/cavewalk-action-cache"))
    ap.add_argument(
        "--source",
        action="append",
        type=source_spec,
        help="'sim', 'gait', 'blind', 'blind2', 'blind3', NAME=sim:KINDS or NAME=DIR, each generator "
        "with @COUNT (repeat); default: sim",
    )
    ap.add_argument("--warp", action="append", default=[], help="source NAME also played at 0.85x and 1.15x")
    ap.add_argument("--sequences", type=int, default=_D.sequences, help="simulated routines (source sim)")
    ap.add_argument("--duration", type=float, default=_D.duration_s, help="seconds per simulated routine")
    ap.add_argument("--epochs", type=int, default=_T.epochs)
    ap.add_argument("--windows-per-epoch", type=int, default=_T.windows_per_epoch)
    ap.add_argument("--slow-channels", type=int, default=_T.slow_channels)
    ap.add_argument("--slow-only", action="store_true", help="no fast pathway (the ablation)")
    ap.add_argument("--window", type=int, default=_T.window, help="frames per window (a multiple of 4)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--members",
        type=int,
        default=1,
        help="networks in the ensemble, the k-th trained with seed --seed + k (default 1: one network)",
    )
    ap.add_argument(
        "--augment",
        action="store_true",
        help="augment the training windows (train.augment_windows: speed, legs, step height, lost joints)",
    )
    ap.add_argument(
        "--augment-share",
        type=share,
        default=_T.augment_share,
        metavar="SHARE",
        help="with --augment, the share of the windows augmented (0 to 1, default 1)",
    )
    ap.add_argument(
        "--arms-still",
        type=share,
        default=_T.arms_still,
        metavar="SHARE",
        help="share of the stepping windows whose arms hang still (train.still_arms; 0 to 1, default 0)",
    )
    ap.add_argument(
        "--threads", type=int, default=1, help="torch threads (1 is fastest on a busy 2-core machine)"
    )


def train_config(args: argparse.Namespace, features: str) -> TrainConfig:
    return replace(
        TrainConfig(),
        epochs=args.epochs,
        windows_per_epoch=args.windows_per_epoch,
        slow_channels=args.slow_channels,
        fast_pathway=not args.slow_only,
        window=args.window,
        seed=args.seed,
        threads=args.threads,
        features=features,
        augment=args.augment,
        augment_share=args.augment_share,
        arms_still=args.arms_still,
    )


def check_train_config(ap: argparse.ArgumentParser, args: argparse.Namespace, features: str) -> None:
    """Before any data is prepared: a bad training setting is one error line (exit 2), at once."""
    try:
        train_config(args, features)
    except ValueError as exc:
        ap.error(str(exc))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "pipeline" / "recognition" / "action.onnx")
    ap.add_argument("--features", choices=list(FEATURE_CHANNELS), default=FEATURES_V2)
    ap.add_argument("--report", type=Path, default=None, help="write the training metrics as JSON here")
    ap.add_argument(
        "--tune-gate",
        action="store_true",
        help="choose the gate's settings on the validation clips (evaluation.tune_gate)",
    )
    ap.add_argument(
        "--same-frame-landing",
        action="store_true",
        help="step evidence from the tracker as it was before 2026-12-06 late morning (a short move could "
        "lift and land within one frame, unseen: StepConfig.defer_landing off; and a quick way back "
        "and step out merged into one swing: StepConfig.turn_split off), as the committed networks "
        "were trained",
    )
    add_arguments(ap)
    args = ap.parse_args()
    check_train_config(ap, args, args.features)
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    def say(msg: str) -> None:
        print(msg, flush=True)

    t0 = time.monotonic()
    sources = args.source or [SourceSpec.parse("sim")]
    sources = [replace(s, warp=s.name in args.warp) for s in sources]
    if args.members < 1:
        raise SystemExit(f"error: --members must be at least 1, got {args.members}")
    seeds = [args.seed + k for k in range(args.members)]
    steps = StepConfig(defer_landing=not args.same_frame_landing, turn_split=not args.same_frame_landing)
    members, member_metrics = [], []
    t_data = 0.0
    for seed in seeds:  # each member: its own draw of the generated sources, its own weights
        t1 = time.monotonic()
        items = prepare_corpus(
            sources, args.cache, args.sequences, args.duration, seed, progress=say, steps=steps
        )
        t_data += time.monotonic() - t1
        tr_items, val_items = split_items(items, _T.validation_fraction, seed)
        if seed == seeds[0]:
            first_items, first_val = items, val_items
        train, val = to_dataset(tr_items), to_dataset(val_items)
        say(f"seed {seed}: {len(train.labels)} training frames, {len(val.labels)} validation frames")
        model, metrics = train_model(train, val, replace(train_config(args, args.features), seed=seed), say)
        members.append(model)
        member_metrics.append({"seed": seed, **metrics})
    items, val_items = first_items, first_val
    meta = {
        "seed": ",".join(str(s) for s in seeds),
        "sources": ",".join(s.name for s in sources),
        "trained": time.strftime("%Y-%m-%d"),
    }
    if len(members) > 1:
        from pipeline.recognition.model import SlowFastEnsemble

        model = SlowFastEnsemble(members)  # type: ignore[arg-type]
        meta["members"] = str(len(members))
        metrics = {
            "parameters": sum(int(m["parameters"]) for m in member_metrics),  # type: ignore[call-overload]
            "members": member_metrics,
        }
    cfg = train_config(args, args.features)
    export_onnx(model, args.out, cfg.window, train.fps, extra=meta, features=args.features)
    size = args.out.stat().st_size
    gate_choice: dict[str, object] | None = None
    if args.tune_gate:
        from pipeline.recognition.evaluation import network_trace, tune_gate
        from pipeline.recognition.recognizer import RecognizerConfig, open_session

        session = open_session(args.out)
        tune_items = [it for it in val_items if it.original]
        traces = [network_trace(session, it.seq.joints_m, it.seq.fps) for it in tune_items]
        gate, table = tune_gate(traces, [it.seq for it in tune_items], RecognizerConfig())
        gate_choice = {"chosen": asdict(gate), "clips": len(tune_items), "grid": table}
        say(f"gate chosen on {len(tune_items)} validation clips of the training sources: {gate}")
    total = time.monotonic() - t0
    say(f"wrote {args.out} ({size / 1024:.0f} KiB, {metrics['parameters']} parameters) in {total:.0f} s")
    if args.report is not None:
        all_ds = to_dataset(items)
        per_source = {s: int(np.sum(all_ds.frame_sources() == s)) for s in sorted(set(all_ds.sources))}
        report = {
            "sources": [s.name for s in sources],
            "frames_per_source": per_source,
            "train": asdict(cfg),
            **metrics,
            "prepare_s": t_data,
            "total_s": total,
            "onnx_bytes": size,
            "gate": gate_choice,
        }
        args.report.write_text(json.dumps(report, indent=2, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
