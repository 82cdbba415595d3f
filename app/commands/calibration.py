"""``cavewalk calibration pattern|layout|checkerboard`` and ``cavewalk calibrate``.

Patterns and layouts come from the CAVE geometry of the settings; ``calibrate``
solves every camera from its images of the walls (PnP on the ArUco markers).
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import numpy as np
import typer
from numpy.typing import NDArray

from app.core.config import get_settings
from pipeline.errors import CalibrationError, InputError

if TYPE_CHECKING:
    from pipeline.calibration.patterns import MarkerLayout

app = typer.Typer()
patterns = typer.Typer(
    help="Wall marker patterns, their layout, checkerboard intrinsics.", no_args_is_help=True
)
app.add_typer(patterns, name="calibration")

VIDEO_SUFFIXES = {".mp4", ".avi", ".mov", ".mkv", ".m4v", ".webm"}


def parse_named_paths(values: list[str], option: str) -> dict[str, list[Path]]:
    """``["cam01=a.png", "cam01=b.png", "cam02=c.png"]`` -> {"cam01": [a, b], "cam02": [c]}."""
    out: dict[str, list[Path]] = {}
    for value in values:
        name, sep, path = value.partition("=")
        if not sep or not name.strip() or not path.strip():
            raise InputError(f"{option} {value!r} must be NAME=PATH, e.g. cam01=wall_view.png")
        out.setdefault(name.strip(), []).append(Path(path.strip()))
    return out


def read_images(name: str, path: Path, max_frames: int) -> list[NDArray[np.uint8]]:
    """The image at ``path``, or up to ``max_frames`` evenly spaced frames of a video."""
    # cv2 and the calibration modules (which import it) are imported where used: cavewalk's start-up time
    import cv2

    if not path.is_file():
        raise InputError(f"{name}: image not found: {path}")
    if path.suffix.lower() in VIDEO_SUFFIXES:
        cap = cv2.VideoCapture(str(path))
        try:
            if not cap.isOpened():
                raise InputError(f"{name}: cannot open video {path}")
            count = int(cap.get(cv2.CAP_PROP_FRAME_COUNT)) or max_frames
            wanted = set(
                np.linspace(0, max(count - 1, 0), min(max_frames, max(count, 1))).round().astype(int)
            )
            frames: list[NDArray[np.uint8]] = []
            index = 0
            while len(frames) < len(wanted):
                ok, frame = cap.read()
                if not ok:
                    break
                if index in wanted:
                    frames.append(np.asarray(frame, dtype=np.uint8))
                index += 1
        finally:
            cap.release()
        if not frames:
            raise InputError(f"{name}: no frame could be read from video {path}")
        return frames
    image = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
    if image is None:
        raise InputError(f"{name}: cannot read image {path} (not an image file OpenCV can decode)")
    return [np.asarray(image, dtype=np.uint8)]


def _layout(layout_path: Path | None) -> MarkerLayout:
    from pipeline.calibration.patterns import load_layout, make_layout

    if layout_path is not None:
        return load_layout(layout_path)
    settings = get_settings()
    return make_layout(settings.cave.geometry(), settings.calibration)


def _write_image(path: Path, image: NDArray[np.uint8]) -> None:
    import cv2

    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        written = cv2.imwrite(str(path), image)
    except cv2.error:
        written = False
    if not written:
        raise InputError(f"cannot write image {path} (unknown extension or unwritable folder)")


@patterns.command("pattern")
def pattern(
    wall: Annotated[str, typer.Option("--wall", help="Wall name (see `cavewalk config show`).")],
    out: Annotated[Path, typer.Option("--out", help="Image file to write (PNG).")],
    layout: Annotated[
        Path | None, typer.Option("--layout", help="Marker layout JSON (default: from the settings).")
    ] = None,
) -> None:
    """Render the ArUco pattern a wall shows during calibration, at the wall's resolution."""
    from pipeline.calibration.patterns import render_wall_pattern

    cave = get_settings().cave.geometry()
    cave.wall(wall)  # unknown wall: one clear message before any work
    lay = _layout(layout)
    image = render_wall_pattern(cave, lay, wall)
    _write_image(out, image)
    typer.echo(f"{wall}: {len(lay.on_wall(wall))} markers, {image.shape[1]}x{image.shape[0]} px -> {out}")

@patterns.command("layout")
def layout_cmd(
    out: Annotated[Path, typer.Option("--out", help="Marker layout JSON to write.")],
) -> None:
    """Write the marker layout JSON (every marker corner in the CAVE frame)."""
    from pipeline.calibration.patterns import save_layout

    lay = _layout(None)
    out.parent.mkdir(parents=True, exist_ok=True)
    save_layout(out, lay)
    typer.echo(f"{len(lay.markers)} markers ({lay.dictionary}) on {', '.join(lay.walls)} -> {out}")

@patterns.command("checkerboard")
def checkerboard(
    image_dir: Annotated[
        list[str], typer.Option("--images", help="NAME=FOLDER of checkerboard images (repeatable).")
    ],
    corners: Annotated[
        tuple[int, int], typer.Option("--corners", help="Inner corners (rows, columns), Pose2Sim order.")
    ] = (4, 7),
    square_mm: Annotated[float, typer.Option("--square-mm", help="Square size, millimetres.")] = 60.0,
    out: Annotated[
        Path | None, typer.Option("--out", help="Write intrinsics as calibration JSON.")
    ] = None,
) -> None:
    """Classic intrinsics from checkerboard images (one folder per camera); prints each RMS."""
    from pipeline.calibration.checkerboard import BoardSpec, calibrate_intrinsics
    from pipeline.calibration.io import save_calibration

    folders = parse_named_paths(image_dir, "--images")
    board = BoardSpec(corners=corners, square_m=square_mm / 1000.0)
    cams = []
    for name, paths in folders.items():
        res = calibrate_intrinsics(name, paths, board)
        typer.echo(res.summary())
        cams.append(res.camera)
    if out is not None:
        save_calibration(out, cams)
        typer.echo(f"intrinsics -> {out} (poses are identity: use `cavewalk calibrate` for extrinsics)")

@app.command("calibrate")
def calibrate(
    image: Annotated[
        list[str],
        typer.Option(
            "--image", help="NAME=PATH of a camera's view of the walls (image or video; repeatable)."
        ),
    ],
    out: Annotated[Path, typer.Option("--out", help="Calibration JSON to write.")],
    layout: Annotated[
        Path | None, typer.Option("--layout", help="Marker layout JSON (default: from the settings).")
    ] = None,
    overlay_dir: Annotated[
        Path | None, typer.Option("--overlay-dir", help="Write a validation overlay PNG per camera here.")
    ] = None,
    toml: Annotated[Path | None, typer.Option("--toml", help="Also write Pose2Sim's TOML here.")] = None,
    max_frames: Annotated[int, typer.Option("--max-frames", min=1, help="Frames used per video.")] = 10,
) -> None:
    """PnP calibration of every camera from its images of the walls' ArUco markers."""
    from pipeline.calibration.io import save_calibration, save_pose2sim_toml
    from pipeline.calibration.overlay import calibration_overlay
    from pipeline.calibration.pnp import calibrate_camera, detect_markers

    settings = get_settings()
    named = parse_named_paths(image, "--image")
    lay = _layout(layout)
    images = {
        name: [img for p in paths for img in read_images(name, p, max_frames)]
        for name, paths in named.items()
    }
    config = settings.calibration
    cave = settings.cave.geometry()
    results, failures = {}, []
    t0 = time.perf_counter()
    for i, (name, imgs) in enumerate(images.items(), 1):
        typer.echo(f"[{i}/{len(images)}] {name}: {len(imgs)} image(s) ...")
        detections = [detect_markers(img, lay.dictionary, config.corner_refinement) for img in imgs]
        try:
            res = calibrate_camera(name, detections, lay, config)
        except CalibrationError as exc:
            failures.append(str(exc))
            typer.echo(f"  {name}: FAILED - {exc}", err=True)
            continue
        results[name] = res
        typer.echo(f"  {res.summary()}")
        if overlay_dir is not None:
            _write_image(overlay_dir / f"{name}_overlay.png", calibration_overlay(res, cave, imgs[0]))
    if failures:
        raise CalibrationError("; ".join(failures))
    cams = [r.camera for r in results.values()]
    out.parent.mkdir(parents=True, exist_ok=True)
    save_calibration(out, cams)
    if toml is not None:
        save_pose2sim_toml(toml, cams)
    typer.echo(f"{len(cams)} cameras calibrated in {time.perf_counter() - t0:.2f} s -> {out}")
    for name, res in results.items():
        typer.echo(f"  {name}: RMS {res.rms_px:.3f} px  {res.verdict}")
