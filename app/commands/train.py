"""``cavewalk train``: fine-tune the action model on recorded takes plus simulator data (issue 18 item 4).

Writes the new model, its card (``M.json``, ``M.md`` beside ``M.onnx``) and registers it in the model
registry (``--db``; ``--no-register`` to skip). Needs the ``train`` extra (torch, onnx).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated

import typer

from app.commands.registry import open_registry
from app.core.config import get_settings
from pipeline.errors import InputError
from pipeline.takes.config import FinetuneConfig

app = typer.Typer()
_D = FinetuneConfig()


@app.command("train")
def train(
    takes: Annotated[
        list[Path],
        typer.Option(
            "--takes", help="Labelled take folders, or folders of takes (repeat, or list after it)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", help="The new model (ONNX); its card goes beside it.")],
    more: Annotated[list[Path] | None, typer.Argument(help="More take folders.", show_default=False)] = None,
    base: Annotated[
        int | None, typer.Option("--base", help="Registry id of the model to start from (default: active).")
    ] = None,
    epochs: Annotated[int, typer.Option("--epochs", min=1, max=50)] = _D.epochs,
    windows: Annotated[int, typer.Option("--windows-per-epoch", min=128)] = _D.windows_per_epoch,
    sim: Annotated[int, typer.Option("--sim", min=0, help="Simulated routines added.")] = _D.sim_routines,
    sim_duration: Annotated[float, typer.Option("--sim-duration", min=4.0)] = _D.sim_duration_s,
    heldout: Annotated[int, typer.Option("--heldout", min=0, help="Simulated test routines.")] = (
        _D.heldout_routines
    ),
    loso: Annotated[bool, typer.Option("--loso/--no-loso", help="Leave-one-participant-out figures.")] = True,
    seed: Annotated[int, typer.Option("--seed")] = 0,
    register: Annotated[bool, typer.Option("--register/--no-register")] = True,
    activate: Annotated[bool, typer.Option("--activate", help="Make the new model the active one.")] = False,
    db: Annotated[Path | None, typer.Option("--db", help="SQLite database (default: paths.db).")] = None,
    progress_json: Annotated[
        bool, typer.Option("--progress-json", help="Progress as JSON lines (the dashboard's worker).")
    ] = False,
) -> None:
    """Fine-tune from the active (or --base) model on labelled takes plus simulator data; write the
    model and its card (data, leave-one-participant-out figures, confusion matrix) and register it."""
    # the trainer (the recogniser's modules; torch when it runs) is imported here: cavewalk's start-up time
    from pipeline.takes.dataset import load_takes
    from pipeline.takes.finetune import require_training, train_on_takes

    require_training()  # before anything else: a clear message when the extra is missing
    settings = get_settings()
    if out.suffix != ".onnx":
        raise InputError(f"--out {out}: give a file name ending in .onnx")
    if out.exists():
        raise InputError(f"--out {out} exists; give a new file name")
    data = load_takes([*takes, *(more or [])])  # every take checked before any work
    config = FinetuneConfig(
        epochs=epochs,
        windows_per_epoch=max(windows, _D.batch_size),
        sim_routines=sim,
        sim_duration_s=sim_duration,
        heldout_routines=heldout,
        loso=loso,
        seed=seed,
    )

    def say(fraction: float, message: str) -> None:
        if progress_json:
            typer.echo(json.dumps({"progress": round(fraction, 4), "message": message}), nl=True)
        else:
            typer.echo(f"[{fraction * 100:5.1f} %] {message}")

    with open_registry(settings, db) as registry:
        start = registry.get(base) if base is not None else registry.active()
        base_path = Path(registry.file_of(start["id"]))
        say(0.0, f"fine-tuning model {start['id']} ({start['name']}) on {len(data)} takes")
        cache = settings.paths.cache_dir
        result = train_on_takes(
            data, out, config, cache / "action-cache", base_path, say, sources_cache=cache
        )
        card = result.card | {"base_model_id": start["id"]}
        out.with_suffix(".json").write_text(json.dumps(card, indent=1, default=str) + "\n", encoding="utf-8")
        out.with_suffix(".md").write_text(result.card_md, encoding="utf-8")
        model_id = None
        if register:
            m = registry.register(
                out,
                card=card,
                card_md=result.card_md,
                name=out.name,
                kind="trained",
                parent_id=start["id"],
                notes=f"cavewalk train on {len(data)} takes",
            )
            model_id = m["id"]
            if activate:
                registry.activate(model_id)
    figures = card["figures"]
    summary = {
        "model_id": model_id,
        "out": str(out),
        "loso_accuracy": figures.get("loso_accuracy"),
        "loso_base_accuracy": figures.get("loso_base_accuracy"),
        "total_s": card["times_s"]["total"],
    }
    if progress_json:
        typer.echo(json.dumps({"done": summary}))
    else:
        typer.echo(f"wrote {out} (+ .json, .md)" + (f"; registered as model {model_id}" if model_id else ""))
