"""The live runtime's one frozen config: the settings' ``[runtime]`` section."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

from pipeline.runtime.logfile import LogFileConfig
from pipeline.sources.grouper import GrouperConfig


@dataclass(frozen=True, slots=True)
class RuntimeConfig:
    """Parameters of the live pipeline.

    target_fps: the rate the processing stages aim at (the dynamic frame rate's ceiling).
    video_pace_fps: delivery rate of video files (None = their own frame rate; 0 = flat out).
    video_loop: loop video files (the dashboard's "videos" source) or play them once.
    grouper: multi-view grouping tolerances (``[runtime.grouper]``); its ``gone_after_s`` also
        marks a camera silent that long as not ok.
    camera_retry_s: a camera that fails is opened again after this long.
    capture_nice: the capture workers' niceness (added to the main process's): decoding
        gives way to pose detection, which is what the frame rate waits for, and takes the
        cores' idle moments instead.
    ring_slots / max_frame_bytes: shared-memory ring of each camera (a frame must fit a slot).
    snapshot_interval_s / snapshot_long_side: dashboard snapshots are re-encoded at most this
        often, at this size.
    start_method: multiprocessing start method of the workers.
    latency_window: latency samples kept per stage for the percentiles.
    stall_after_s: a running pipeline that fused no frame for this long reports ``stalled``.
    log: the server's log file, which the workers append to as well (``[runtime.log]``,
        :mod:`pipeline.runtime.logfile`).
    """

    target_fps: float = 30.0
    video_pace_fps: float | None = None
    video_loop: bool = True
    grouper: GrouperConfig = field(default_factory=GrouperConfig)
    camera_retry_s: float = 1.0
    capture_nice: int = 5
    ring_slots: int = 3
    max_frame_bytes: int = 3840 * 2160 * 3
    snapshot_interval_s: float = 0.2
    snapshot_long_side: int = 640
    start_method: Literal["forkserver", "spawn", "fork"] = "forkserver"
    latency_window: int = 600
    stall_after_s: float = 0.5
    log: LogFileConfig = field(default_factory=LogFileConfig)

    def __post_init__(self) -> None:
        if self.target_fps <= 0:
            raise ValueError(f"target_fps must be > 0, got {self.target_fps}")
        if self.video_pace_fps is not None and self.video_pace_fps < 0:
            raise ValueError(f"video_pace_fps must be >= 0 or None, got {self.video_pace_fps}")
        if self.camera_retry_s <= 0 or self.stall_after_s <= 0 or self.snapshot_interval_s < 0:
            raise ValueError(f"camera_retry_s and stall_after_s must be > 0 and snapshot_interval_s >= 0, "
                             f"got {self.camera_retry_s}, {self.stall_after_s}, {self.snapshot_interval_s}")
        if self.ring_slots < 2 or self.max_frame_bytes <= 0:
            raise ValueError(f"ring_slots must be >= 2 and max_frame_bytes > 0, got {self.ring_slots}, "
                             f"{self.max_frame_bytes}")
        if not 0 <= self.capture_nice <= 19:
            raise ValueError(f"capture_nice must be in 0..19, got {self.capture_nice}")
        if self.start_method not in ("forkserver", "spawn", "fork"):
            raise ValueError(f"start_method must be forkserver, spawn or fork, got {self.start_method!r}")
        if self.latency_window < 1 or self.snapshot_long_side < 16:
            raise ValueError(f"latency_window must be >= 1 and snapshot_long_side >= 16, got "
                             f"{self.latency_window}, {self.snapshot_long_side}")
