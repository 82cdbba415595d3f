#!/usr/bin/env python
"""Train the skeleton SlowFast action model on simulated users and export it to ONNX.

    .venv/bin/python scripts/train_action.py            # -> pipeline/recognition/action.onnx
    .venv/bin/python scripts/train_action.py --sequences 40 --epochs 2 --out /tmp/a.onnx   # a quick try

Needs the ``train`` extra (torch, onnx). The simulated data are cached in --cache
(one .npz per data configuration), so a second run only trains. Deterministic for a seed.
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

from pipeline.recognition.train import (  # noqa: E402
    DataConfig,
    TrainConfig,
    export_onnx,
    load_or_generate,
    train_model,
)

_D, _T = DataConfig(), TrainConfig()


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=ROOT / "pipeline" / "recognition" / "action.onnx")
    ap.add_argument("--cache", type=Path, default=Path("/tmp/cavewalk-action-cache"))
    ap.add_argument("--sequences", type=int, default=_D.sequences)
    ap.add_argument("--duration", type=float, default=_D.duration_s, help="seconds per routine")
    ap.add_argument("--epochs", type=int, default=_T.epochs)
    ap.add_argument("--windows-per-epoch", type=int, default=_T.windows_per_epoch)
    ap.add_argument("--slow-channels", type=int, default=_T.slow_channels)
    ap.add_argument("--slow-only", action="store_true", help="no fast pathway (the ablation)")
    ap.add_argument("--window", type=int, default=_T.window, help="frames per window (a multiple of 4)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--threads", type=int, default=1, help="torch threads (1 is fastest on a busy 2-core machine)"
    )
    ap.add_argument("--report", type=Path, default=None, help="write the training metrics as JSON here")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")

    def say(msg: str) -> None:
        print(msg, flush=True)

    data_cfg = replace(DataConfig(), sequences=args.sequences, duration_s=args.duration, seed=args.seed)
    train_cfg = replace(
        TrainConfig(),
        epochs=args.epochs,
        windows_per_epoch=args.windows_per_epoch,
        slow_channels=args.slow_channels,
        fast_pathway=not args.slow_only,
        window=args.window,
        seed=args.seed,
        threads=args.threads,
    )
    t0 = time.monotonic()
    say(
        f"data: {data_cfg.sequences} routines of {data_cfg.duration_s:g} s at {data_cfg.fps:g} fps "
        f"(seed {data_cfg.seed}, cache {args.cache})"
    )
    data = load_or_generate(data_cfg, args.cache, progress=say)
    import numpy as np

    n_val = max(1, round(data.num_sequences * train_cfg.validation_fraction))
    order = np.random.default_rng(args.seed).permutation(data.num_sequences)
    train, val = data.subset(np.sort(order[n_val:])), data.subset(np.sort(order[:n_val]))
    say(
        f"{len(train.labels)} training frames, {len(val.labels)} validation frames "
        f"({time.monotonic() - t0:.0f} s)"
    )
    model, metrics = train_model(train, val, train_cfg, progress=say)
    export_onnx(
        model,
        args.out,
        train_cfg.window,
        data.fps,
        extra={
            "seed": str(args.seed),
            "sequences": str(data_cfg.sequences),
            "trained": time.strftime("%Y-%m-%d"),
        },
    )
    size = args.out.stat().st_size
    say(
        f"wrote {args.out} ({size / 1024:.0f} KiB, {metrics['parameters']} parameters) "
        f"in {time.monotonic() - t0:.0f} s"
    )
    if args.report is not None:
        report = {"data": asdict(data_cfg), "train": asdict(train_cfg), **metrics, "onnx_bytes": size}
        args.report.write_text(json.dumps(report, indent=2, default=str) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
