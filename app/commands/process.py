"""``cavewalk process``: the recognition pipeline, offline, over synchronised videos."""

from __future__ import annotations

import logging
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from app.core.config import get_settings
from pipeline.errors import InputError

if TYPE_CHECKING:
    from pipeline.camera import Camera
    from pipeline.runtime.offline import RunSummary, SyncedVideos

log = logging.getLogger(__name__)

app = typer.Typer()


def _calibrated_cameras(path: Path, cameras: list[str]) -> list[Camera]:
    """The calibration's cameras for the videos, in video order; every video must be calibrated."""
    # the pipeline (cv2, scipy, onnxruntime) is imported where it is used, not at the top: cavewalk's start-up
    from pipeline.calibration.io import load_calibration

    by_name = {c.name: c for c in load_calibration(path)}
    missing = [c for c in cameras if c not in by_name]
    if missing:
        raise InputError(
            f"calibration {path} has cameras {list(by_name)} but not {missing} named by --video "
            f"(video names must match the calibration's camera names)"
        )
    return [by_name[c] for c in cameras]


def _check_out(out: Path) -> None:
    if out.is_dir():
        raise InputError(f"--out {out} is a directory; give a .jsonl file path")
    parent = out.parent if str(out.parent) else Path(".")
    if parent.exists() and not parent.is_dir():
        raise InputError(f"--out {out}: {parent} is not a directory")


def _report_short_videos(videos: SyncedVideos, done: int, expected: int) -> str:
    """Warn (stderr) when the run wrote fewer frames than the files report: how many frames
    each view really had and where the short ones ended. Returns the warning ('' if none)."""
    if not videos.ended or not expected or done >= expected:
        return ""  # every file had what it says, --frames stopped the run first, or no count to go by
    had = videos.frames_had()
    short = videos.shortfall()
    views = "; ".join(
        f"{cam}: {n} frames" + (f" (its file reports {short[cam][1]}: it ends at frame {n})" if cam in short
                                else "")
        for cam, n in had.items()
    )
    message = (f"warning: the videos ran out after {done} multi-view frames, fewer than the "
               f"{expected or '?'} their files report -- {views}. Frames are written while every view "
               "has one; a truncated or damaged video ends the run early.")
    typer.echo(message, err=True)
    return views


@app.command("process")
def process(
    video: Annotated[list[str], typer.Option(
        "--video", help="NAME=PATH, one per camera (names as in the calibration).",
    )],
    calibration: Annotated[Path, typer.Option(
        "--calibration", help="Calibration (JSON, Pose2Sim TOML or Qualisys .qca.txt).",
    )],
    out: Annotated[Path, typer.Option("--out", help="Per-frame results, JSON Lines.")],
    frames: Annotated[int | None, typer.Option(
        "--frames", min=1, help="Process only the first N frames.",
    )] = None,
    roi: Annotated[bool | None, typer.Option(
        "--roi/--no-roi",
        help="Crop around tracked people between full-frame passes (default: settings).",
    )] = None,
) -> None:
    """The whole recognition pipeline over synchronised videos: detection, tracking, 3D skeletons,
    navigator and action per frame, as the per-frame JSON Lines of SPEC.md.

    Frames are written while every view has one. A video that ends before the frames its file
    reports (truncated, damaged) ends the run there with a warning naming how many frames each
    view really had; the exit status is 0 when some frames were written, 2 when none could be."""
    from app.services.pipeline_factory import chain_config
    from pipeline.results import ResultsWriter
    from pipeline.runtime.chain import PoseModel, build_chain
    from pipeline.runtime.offline import OfflinePipeline, SyncedVideos, parse_named_paths

    settings = get_settings()
    named = parse_named_paths(video, "video")
    cameras = _calibrated_cameras(calibration, list(named))
    _check_out(out)
    pose = settings.pose if roi is None else replace(settings.pose, roi=roi)
    with SyncedVideos(named) as videos:
        chain = chain_config(settings).with_views(PoseModel(pose, settings.pose_model_path), videos.cameras,
                                                  tuple(cameras))
        pipeline = OfflinePipeline(build_chain(chain, need_actions=True))
        total = videos.frame_count if frames is None else min(frames, videos.frame_count or frames)
        typer.echo(f"processing {len(named)} videos, {total or '?'} frames (as the files report) at "
                   f"{videos.fps:g} fps (ROI mode {'on' if pose.roi else 'off'}) -> {out}", err=True)
        step = max(1, (total or 100) // 20)

        def progress(done: int, total: int, summary: RunSummary) -> None:
            if done % step == 0 or done == total:
                typer.echo(f"  frame {done}/{total or '?'}  detect+track median "
                           f"{summary.median_ms():.1f} ms/frame", err=True)

        out.parent.mkdir(parents=True, exist_ok=True)
        partial = out.with_name(out.name + ".partial")
        try:
            with ResultsWriter(partial) as writer:
                summary = pipeline.run(videos, writer, max_frames=frames, progress=progress)
            short = _report_short_videos(videos, summary.frames, total)
            if summary.frames == 0:
                raise InputError(f"no frame could be processed: {short or 'the videos have no frames'}")
            partial.replace(out)
        finally:
            partial.unlink(missing_ok=True)
    fulls = sum(t.full for t in summary.timings)
    typer.echo(f"wrote {summary.frames} frames to {out} in {summary.wall_s:.1f} s "
               f"(detect+track median {summary.median_ms():.1f} ms/frame, "
               f"{fulls} full-frame passes)")
    actions = ", ".join(f"{k}: {n}" for k, n in sorted(summary.actions.items())) or "none"
    typer.echo(f"  3D people in {summary.people3d_frames} frames, a navigator in "
               f"{summary.navigator_frames}; actions {actions}")
    for cam, counts in summary.track_frames.items():
        ids = ", ".join(f"#{tid}: {n}" for tid, n in sorted(counts.items())) or "nobody"
        typer.echo(f"  {cam}: frames per track id {ids}")
