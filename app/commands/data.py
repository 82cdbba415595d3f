"""``cavewalk data demo``: fetch the real multi-view demo videos."""

from __future__ import annotations

import typer

from app.core.config import get_settings


def register(cli: typer.Typer) -> None:
    group = typer.Typer(help="Demo data.", no_args_is_help=True)

    @group.command("demo")
    def demo() -> None:
        """Download Pose2Sim's Demo_SinglePerson (4 synchronised videos + calibration) into the cache."""
        from pipeline.demo_data import fetch_demo

        data = fetch_demo(get_settings().paths.cache_dir, progress=typer.echo)
        for name, path in data.videos.items():
            typer.echo(f"  {name}: {path}")
        typer.echo(f"  calibration: {data.calibration}")

    cli.add_typer(group, name="data")
