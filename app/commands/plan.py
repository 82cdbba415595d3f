"""``cavewalk plan``: camera-coverage heat maps (PNG, SVG) and their numbers (JSON), or a mount search.

The cameras: ``--calibration C`` (a calibration JSON, Pose2Sim TOML or Qualisys qca, or a proposed
set written as calibration JSON), else the settings' ``paths.calibration``, else the simulator's
default layout; ``--cameras N`` searches mounts for N cameras instead. The CAVE is the settings'.
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

import typer

from app.core.config import get_settings
from pipeline.errors import InputError

REGION_ORDER = ("centre", "inner", "edges", "corners")


def _regions_table(regions: dict[str, Any], floor: dict[str, Any]) -> list[str]:
    lines = [f"  {'region':8s} {'cells':>5s} {'error':>9s} {'valid':>7s} {'views':>6s} {'>=2 cams':>9s}"]
    for name in (*REGION_ORDER, "floor"):
        r = floor if name == "floor" else regions.get(name)
        if r is None:
            continue
        err = "–" if r["error_mm"] is None else f"{r['error_mm']:.1f} mm"
        lines.append(
            f"  {name:8s} {r['cells']:5d} {err:>9s} {100 * (r['valid'] or 0):6.1f}% "
            f"{r['views'] or 0:6.2f} {100 * (r['covered2'] or 0):8.1f}%"
        )
    return lines

app = typer.Typer()


@app.command("plan")
def plan(
    out: Annotated[Path, typer.Option("--out", help="Folder for plan.json and the PNG / SVG figures.")],
    calibration: Annotated[
        Path | None,
        typer.Option(
            "--calibration",
            help="Cameras to map: calibration JSON, Pose2Sim TOML or Qualisys .qca.txt "
            "(default: paths.calibration, else the simulator's default layout).",
        ),
    ] = None,
    cameras: Annotated[
        int | None,
        typer.Option(
            "--cameras",
            help="Search mounts (top corners, wall middles, heights, pan, tilt) for N cameras.",
        ),
    ] = None,
    grid: Annotated[
        float | None, typer.Option("--grid", help="Floor cell side, m (planner.grid_step_m).")
    ] = None,
    samples: Annotated[
        int | None,
        typer.Option(
            "--samples", help="Monte Carlo draws per cell, height and facing (planner.samples)."
        ),
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed of the Monte Carlo.")] = None,
    preset: Annotated[
        str | None,
        typer.Option(
            "--preset",
            help="Camera model of searched mounts: kinect_color or depth (default sim.camera_preset).",
        ),
    ] = None,
    top: Annotated[
        int | None, typer.Option("--top", help="Best layouts to map and show (planner.top_k).")
    ] = None,
) -> None:
    """Floor heat maps of how many cameras see a standing person's joints and the expected 3D error."""
    # the planner and the calibration reader pull cv2 and scipy: imported here for cavewalk's start-up time
    from app.services.planner import default_layout, run_plan
    from pipeline.calibration.io import load_calibration
    from pipeline.planner.plan import write_plan

    settings = get_settings()
    if calibration is not None and cameras is not None:
        raise InputError(
            "give --calibration C (map those cameras) or --cameras N (search mounts), not both"
        )
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} is a file; give a folder")
    if cameras is None and (preset is not None or top is not None):
        raise InputError("--preset and --top go with --cameras N (the mount search)")
    overrides: dict[str, Any] = {"grid_step_m": grid, "samples": samples, "seed": seed}
    with typer.progressbar(length=100, label="planning", file=None) as bar:
        done = [0]

        def progress(fraction: float, _message: str) -> None:
            step = int(100 * fraction) - done[0]
            if step > 0:
                bar.update(step)
                done[0] += step

        if cameras is not None:
            if cameras < 2:
                raise InputError(
                    f"--cameras must be at least 2 (triangulation needs two views), got {cameras}"
                )
            result = run_plan(
                settings,
                count=cameras,
                overrides={**overrides, "preset": preset, "top_k": top},
                progress=progress,
            )
        else:
            path = calibration or settings.paths.calibration
            if path is not None:
                cams, source = load_calibration(path), str(path)
            else:
                cams, source = default_layout(settings), f"default layout ({settings.sim.camera_preset})"
            result = run_plan(
                settings, cameras=cams, source=source, overrides=overrides, progress=progress
            )
    files = write_plan(result, out)
    data = result.to_dict()
    summary = data["summary"]
    typer.echo(f"{data['source']}:")
    best = result.best
    typer.echo(
        f"  {len(best.cameras)} cameras, {int(best.grid.used.sum())} floor cells of "
        f"{best.config.grid_step_m:g} m, map in {summary['map_seconds']:.1f} s "
        f"(visibility {best.timings_s['visibility']:.2f} s, Monte Carlo "
        f"{best.timings_s['monte_carlo']:.2f} s); whole plan {data['elapsed_s']:.1f} s"
    )
    typer.echo("\n".join(_regions_table(summary["regions"], best.floor.to_dict())))
    if result.search is not None:
        typer.echo("layouts (objective = mean and worst-region error, uncovered joints charged):")
        rows = [
            *data["search"]["layouts"],
            *([data["search"]["default"]] if data["search"]["default"] else []),
        ]
        for r in rows:
            typer.echo(
                f"  {r['name']:8s} objective {r['objective_mm']:6.1f}  mean {r['mean_error_mm']} mm  "
                f"centre {r['centre_error_mm']} mm  corners {r['corner_error_mm']} mm  "
                f">=2 cams {100 * (r['covered2'] or 0):.0f} %  valid {100 * (r['valid'] or 0):.0f} %"
            )
            for mount in r["mounts"] or []:
                typer.echo(f"           {mount['label']}")
    for f in files:
        typer.echo(f"  -> {f}")
