"""The run plan: which capture workers a start needs, checked before anything is stopped.

:func:`plan_run` turns a start request (a source and, for ``videos``, the files) into the
camera name -> source URI map of the capture workers (empty for the simulator), or raises
one :class:`~pipeline.errors.CavewalkError` that says what is wrong; a running pipeline is
left as it was.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from pipeline.camera import Camera
from pipeline.errors import InputError, SourceError
from pipeline.runtime.config import RuntimeConfig
from pipeline.sources import source_kind
from pipeline.sources.opencv import probe_video

SourceName = Literal["simulator", "cameras", "videos"]
SOURCES: tuple[str, ...] = ("simulator", "cameras", "videos")


@dataclass(frozen=True, slots=True)
class PlanInputs:
    """What a plan is checked against: the runtime's config and the pipeline's parts."""

    config: RuntimeConfig
    camera_sources: dict[str, str]
    cameras_calibrated: tuple[Camera, ...] | None
    has_pose: bool
    has_simulator: bool


def slot_bytes(width: int, height: int) -> int:
    """A video's ring slot: its frame size, with room for decoders that pad to 16 pixels."""
    return (width + 16) * (height + 16) * 3


def plan_run(source: str, videos: dict[str, Path] | None, inputs: PlanInputs) -> dict[str, str]:
    """camera name -> source URI for the capture workers ({} for the simulator)."""
    if source not in SOURCES:
        raise InputError(f"source must be one of {', '.join(SOURCES)}, got {source!r}")
    if source == "simulator":
        if not inputs.has_simulator:
            raise SourceError("the simulator is not available in this pipeline")
        return {}
    plan = _camera_plan(inputs.camera_sources) if source == "cameras" else _video_plan(videos)
    if inputs.cameras_calibrated is not None:
        known = {c.name for c in inputs.cameras_calibrated}
        unknown = sorted(set(plan) - known)
        if unknown:
            raise InputError(f"cameras {unknown} are not in the calibration (it has {sorted(known)})")
    if not inputs.has_pose:
        raise SourceError("no pose detector configured for image sources")
    for name, uri in plan.items():
        if source_kind(uri) == "video":
            (w, h), _ = probe_video(name, Path(uri))
            if slot_bytes(w, h) > inputs.config.max_frame_bytes:
                raise SourceError(f"camera {name}: {w}x{h} frames exceed the ring slots "
                                  f"({inputs.config.max_frame_bytes} bytes)")
    return plan


def _camera_plan(camera_sources: dict[str, str]) -> dict[str, str]:
    plan = {n: u for n, u in camera_sources.items() if source_kind(u) != "sim"}
    if not plan:
        raise SourceError("no camera has a real source in the settings (all are 'sim'); "
                          "set cameras[].source to a device index, URL, video or folder")
    for name, uri in plan.items():
        if source_kind(uri) in ("video", "folder") and not Path(uri).expanduser().exists():
            raise SourceError(f"camera {name}: source {uri!r} not found")
    return plan


def _video_plan(videos: dict[str, Path] | None) -> dict[str, str]:
    if not videos:
        raise InputError("the videos source needs at least one video (camera name -> file)")
    plan = {}
    for name, path in videos.items():
        if not Path(path).is_file():
            raise InputError(f"camera {name}: video not found: {path}")
        plan[name] = str(path)
    return plan
