"""``cavewalk simulate``: a simulated navigator (and bystanders) as a skeleton sequence and 2D views."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import Annotated

import numpy as np
import typer

from app.core.config import get_settings
from pipeline.errors import InputError
from pipeline.sim.script import load_script
from pipeline.skeleton import SkeletonSequence, save_npz

app = typer.Typer()

DEFAULT_RANDOM_S = 60.0


@app.command("simulate")
def simulate(
    out: Annotated[
        Path,
        typer.Option(
            "--out", help="Skeleton sequence NPZ to write (joints, fps, labels, tags, contacts, source)."
        ),
    ],
    script: Annotated[
        Path | None, typer.Option("--script", help="Routine JSON/TOML; default: a random routine.")
    ] = None,
    keypoints: Annotated[
        Path | None, typer.Option("--keypoints", help="Also write the cameras' 2D views as JSON Lines.")
    ] = None,
    fps: Annotated[
        float | None, typer.Option("--fps", help="Frames per second (default: settings).")
    ] = None,
    seed: Annotated[int | None, typer.Option("--seed", help="Random seed (default: settings).")] = None,
    bystanders: Annotated[
        int | None, typer.Option("--bystanders", help="People besides the navigator (default: settings).")
    ] = None,
    duration: Annotated[
        float | None,
        typer.Option(
            "--duration", help=f"Seconds (default: the script's length, or {DEFAULT_RANDOM_S:g})."
        ),
    ] = None,
    preset: Annotated[
        str | None,
        typer.Option("--preset", help="Camera preset: kinect_color or depth (default: settings)."),
    ] = None,
) -> None:
    """Simulate a user in the CAVE: the navigator's 3D skeleton with ground-truth labels (NPZ),
    and with --keypoints what the virtual cameras' pose detector reports (per-frame JSON Lines;
    track ids and 3D people are the ground truth, 0 = the navigator)."""
    # the simulator and the results writer pull scipy: imported here for cavewalk's start-up time
    from pipeline.results import ResultsWriter
    from pipeline.sim.world import SimWorld

    settings = get_settings()
    script_path = script if script is not None else settings.sim.script
    routine = load_script(script_path) if script_path is not None else None
    if duration is not None and not (math.isfinite(duration) and duration > 0):
        raise InputError(f"--duration must be a positive number of seconds, got {duration}")
    seconds = duration if duration is not None else (routine.duration_s if routine else DEFAULT_RANDOM_S)
    overrides: dict[str, object] = {"observe": keypoints is not None}
    for key, value in (
        ("fps", fps),
        ("seed", seed),
        ("bystanders", bystanders),
        ("camera_preset", preset),
    ):
        if value is not None:
            overrides[key] = value
    config = replace(settings.sim, **overrides)  # type: ignore[arg-type]
    for path in (out, keypoints):
        if path is not None and path.is_dir():
            raise InputError(f"{path} is a folder; give a file name")
    world = SimWorld.build(settings.cave.geometry(), config, routine)
    n_frames = max(1, round(seconds * config.fps))

    joints, labels, tags, contacts = [], [], [], []
    try:
        writer = ResultsWriter(keypoints) if keypoints is not None else None
    except OSError as exc:
        raise InputError(f"cannot write {keypoints}: {exc}") from exc
    try:
        with typer.progressbar(world.run(n_frames), length=n_frames, label="simulating") as frames:
            for frame in frames:
                joints.append(frame.navigator_joints)
                labels.append(frame.label)
                tags.append(frame.tag)
                contacts.append(frame.contacts)
                if writer is not None:
                    writer.write(frame.to_result())
    finally:
        if writer is not None:
            writer.close()
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        feet = np.asarray(contacts, dtype=bool)
        seq = SkeletonSequence(np.asarray(joints), config.fps, tuple(labels), tuple(tags), feet, "sim")
        save_npz(out, seq)
    except OSError as exc:
        raise InputError(f"cannot write {out}: {exc}") from exc
    counts = {lb: labels.count(lb) for lb in dict.fromkeys(labels)}
    typer.echo(
        f"{out}: {n_frames} frames at {config.fps:g} fps ({n_frames / config.fps:.1f} s), "
        f"{1 + config.bystanders} people; frames per label: "
        + ", ".join(f"{k} {v}" for k, v in counts.items())
    )
    if keypoints is not None:
        typer.echo(f"{keypoints}: 2D views of {len(world.cameras)} {config.camera_preset} cameras")
