"""``cavewalk evaluate``: the recogniser scored on labelled skeleton sequences (the model card's code)."""

from __future__ import annotations

import json
import math
import os
import tempfile
from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any

import typer

from app.commands.registry import open_registry
from app.core.config import get_settings
from pipeline.errors import InputError


def _finite(obj: Any) -> Any:
    """JSON has no inf/NaN: they become null."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_finite(v) for v in obj]
    return obj


app = typer.Typer()


@app.command("evaluate")
def evaluate(
    skeletons: Annotated[
        list[Path] | None,
        typer.Option(
            "--skeletons",
            help="Labelled skeleton NPZ files (joints, fps, labels; optional tags, contacts, source). "
            "More files may follow the first: --skeletons A.npz B.npz ...",
        ),
    ] = None,
    more: Annotated[
        list[Path] | None, typer.Argument(help="More labelled NPZ files.", show_default=False)
    ] = None,
    model: Annotated[
        Path | None, typer.Option("--model", help="Action model ONNX (default: from the settings).")
    ] = None,
    takes: Annotated[
        list[Path] | None,
        typer.Option(
            "--takes", help="Labelled take folders, or folders of takes (the participant's frames)."
        ),
    ] = None,
    model_id: Annotated[
        int | None, typer.Option("--model-id", help="A registered model (cavewalk models list) instead.")
    ] = None,
    db: Annotated[
        Path | None, typer.Option("--db", help="The registry's database (with --model-id).")
    ] = None,
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Also write the whole report as JSON here.")
    ] = None,
    exclude: Annotated[
        float,
        typer.Option("--exclude", min=0.0, help="Seconds after each true change left out of frame figures."),
    ] = 0.3,
) -> None:
    """Per-class precision/recall, frame accuracy, macro-F1, confusion, start/stop latency and false
    movement per tag of the recogniser on labelled skeleton sequences."""
    # the recogniser and its data are imported by the command that runs them: cavewalk's start-up time
    from pipeline.recognition.dataset import load_labelled
    from pipeline.recognition.evaluation import evaluate_recognizer
    from pipeline.recognition.metrics import text_report
    from pipeline.recognition.recognizer import ActionRecognizer
    from pipeline.takes.dataset import load_takes

    paths = [*(skeletons or []), *(more or [])]
    if not paths and not takes:
        raise InputError("give labelled skeleton files with --skeletons, or take folders with --takes")
    if model is not None and model_id is not None:
        raise InputError("give --model or --model-id, not both")
    if json_out is not None and json_out.is_dir():
        raise InputError(f"--json {json_out} is a directory; give a file name")
    sequences = [load_labelled(p) for p in paths]  # every file checked before any work
    sequences += [t.seq for t in load_takes(takes)] if takes else []
    config = get_settings().recognition
    if model_id is not None:
        with open_registry(get_settings(), db) as registry:
            model = Path(registry.file_of(model_id))
    if model is not None:
        config = replace(config, model_path=model)
    recognizer = ActionRecognizer.from_config(config)
    frames = sum(len(s) for s in sequences)
    with typer.progressbar(length=frames, label="evaluating", file=None) as bar:
        report = evaluate_recognizer(recognizer, sequences, exclude, progress=lambda s: bar.update(len(s)))
    typer.echo(text_report(report), nl=False)
    if json_out is not None:
        data = _finite(report.to_dict()) | {
            "files": [str(p) for p in paths] + [str(t) for t in takes or []],
            "model": str(config.model_path),
        }
        json_out.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".evaluate-", suffix=".json", dir=json_out.parent)
        try:
            with os.fdopen(fd, "w", encoding="utf-8") as fh:
                json.dump(data, fh, indent=2)
                fh.write("\n")
            os.replace(tmp, json_out)
        except BaseException:
            Path(tmp).unlink(missing_ok=True)
            raise
        typer.echo(f"wrote {json_out}")
