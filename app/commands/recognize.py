"""``cavewalk recognize``: action, yaw and speed for each frame of a skeleton sequence."""

from __future__ import annotations

import json
import os
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from app.core.config import get_settings
from pipeline.errors import InputError
from pipeline.recognition.recognizer import ActionRecognizer, recognize_sequence
from pipeline.skeleton import load_npz

app = typer.Typer()


@app.command("recognize")
def recognize(
    skeletons: Annotated[
        Path, typer.Option("--skeletons", help="Skeleton sequence NPZ (joints (T, 17, 3), fps).")
    ],
    out: Annotated[Path, typer.Option("--out", help="Output JSON Lines, one object per input frame.")],
    model: Annotated[
        Path | None, typer.Option("--model", help="Action model ONNX (default: from the settings).")
    ] = None,
) -> None:
    """Recognise still / forward / left / right, facing yaw and speed in every frame of S.npz."""
    seq = load_npz(skeletons)
    if len(seq) == 0:
        raise InputError(f"{skeletons}: the sequence has no frames")
    if out.is_dir():
        raise InputError(f"--out {out} is a directory; give a file name")
    config = get_settings().recognition
    if model is not None:
        config = replace(config, model_path=model)
    recognizer = ActionRecognizer.from_config(config)
    if abs(seq.fps - recognizer.fps) > 1e-6:
        typer.echo(f"{skeletons}: {seq.fps:g} fps, resampled to the model's {recognizer.fps:g} fps")
    with typer.progressbar(length=len(seq), label="recognising", file=None) as bar:
        estimates = recognize_sequence(recognizer, seq.joints_m, seq.fps, progress=bar.update)
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=".recognize-", suffix=".jsonl", dir=out.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            for i, est in enumerate(estimates):
                record = {
                    "frame": i,
                    "action": est.label,
                    "probs": {k: round(v, 4) for k, v in est.probs.items()},
                    "yaw_deg": round(est.yaw_deg, 2),
                    "speed_mps": round(est.speed_mps, 3),
                }
                if est.no_data:
                    record["no_data"] = True
                fh.write(json.dumps(record) + "\n")
        os.replace(tmp, out)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    labels = [e.label for e in estimates]
    counts = {a: labels.count(a) for a in dict.fromkeys(labels)}
    moving = float(np.mean([lab != "still" for lab in labels]))
    typer.echo(f"{out}: {len(estimates)} frames, {counts}, moving {moving:.0%}")
    blind = sum(e.no_data for e in estimates)
    if blind:
        typer.echo(
            f"warning: {blind} of {len(estimates)} frames had no usable skeleton (no known leg joint): "
            "still, confidence 0",
            err=True,
        )
