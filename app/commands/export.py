"""``cavewalk export``: a take as a zip or folder (SPEC files + videos + TRC + labels table), as TRC
markers for Pose2Sim/OpenSim, or as a per-frame labels CSV for R/SPSS."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from pipeline.errors import InputError
from pipeline.takes.export import FORMATS, write_export

app = typer.Typer()


@app.command("export")
def export_cmd(
    take: Annotated[Path, typer.Argument(help="The take's folder (with its take.json).")],
    out: Annotated[Path, typer.Option("--out", help="The file (or folder) to write; must not exist.")],
    fmt: Annotated[
        str, typer.Option("--format", help=f"{', '.join(FORMATS)} (default: from --out's suffix, else zip).")
    ] = "",
    user: Annotated[
        int | None, typer.Option("--user", help="trc: the person's user id (default: the participant).")
    ] = None,
) -> None:
    """Export a take: zip/folder (take.json, skeletons.npz, frames.jsonl, labels.csv, calibration,
    videos, trc/*.trc, labels_frames.csv), trc (metres, Y-up) or labels (one row per frame)."""
    if not fmt:
        fmt = {".zip": "zip", ".trc": "trc", ".csv": "labels"}.get(out.suffix.lower(), "zip")
    if fmt not in FORMATS:
        raise InputError(f"--format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    if user is not None and fmt != "trc":
        raise InputError("--user is for --format trc (the zip and folder hold every person's TRC)")
    written = write_export(take, out, fmt, user)
    typer.echo(f"exported {take} as {fmt} to {out} ({len(written)} file{'s' if len(written) != 1 else ''})")
