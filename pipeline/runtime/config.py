"""The runtime's own configuration, built from ``settings.runtime`` by ``RuntimeConfig.from_settings``."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from pipeline.sources.grouper import GrouperConfig


@dataclass(frozen=True, slots=True)
class RuntimeConfig:
    """Parameters of the live pipeline.

    target_fps: the rate the processing stages aim at (the dynamic frame rate's ceiling).
    emit_rate_hz / heartbeat_s: the UDP stream (SPEC protocol v1).
    video_pace_fps: delivery rate of video files (None = their own frame rate; 0 = flat out).
    video_loop: loop video files (the dashboard's "videos" source) or play them once.
    ring_slots / max_frame_bytes: shared-memory ring of each camera (a frame must fit a slot).
    grouper: multi-view grouping tolerances.
    snapshot_interval_s: dashboard snapshots are re-encoded at most this often.
    start_method: multiprocessing start method of the workers.
    osc: OSC destinations (host, port) that also get ``/cave/locomotion``.
    capture_nice: the capture workers' niceness (added to the main process's): decoding
        gives way to pose detection, which is what the frame rate waits for, and takes the
        cores' idle moments instead.
    """

    target_fps: float = 30.0
    emit_rate_hz: float = 60.0
    heartbeat_s: float = 1.0
    video_pace_fps: float | None = None
    video_loop: bool = True
    ring_slots: int = 3
    max_frame_bytes: int = 3840 * 2160 * 3
    grouper: GrouperConfig = field(default_factory=GrouperConfig)
    snapshot_interval_s: float = 0.2
    snapshot_long_side: int = 640
    camera_retry_s: float = 1.0
    start_method: Literal["forkserver", "spawn", "fork"] = "forkserver"
    osc: tuple[tuple[str, int], ...] = ()
    latency_window: int = 600
    capture_nice: int = 5

    def __post_init__(self) -> None:
        if self.target_fps <= 0 or self.emit_rate_hz <= 0 or self.heartbeat_s <= 0:
            raise ValueError(f"target_fps, emit_rate_hz and heartbeat_s must be > 0, got {self.target_fps}, "
                             f"{self.emit_rate_hz}, {self.heartbeat_s}")
        if self.video_pace_fps is not None and self.video_pace_fps < 0:
            raise ValueError(f"video_pace_fps must be >= 0 or None, got {self.video_pace_fps}")
        if self.ring_slots < 2 or self.max_frame_bytes <= 0:
            raise ValueError(f"need ring_slots >= 2 and max_frame_bytes > 0, got {self.ring_slots}, "
                             f"{self.max_frame_bytes}")
        if not 0 <= self.capture_nice <= 19:
            raise ValueError(f"capture_nice must be in 0..19, got {self.capture_nice}")
        if self.start_method not in ("forkserver", "spawn", "fork"):
            raise ValueError(f"start_method must be forkserver, spawn or fork, got {self.start_method!r}")

    @classmethod
    def from_settings(cls, runtime: Any) -> RuntimeConfig:
        """From ``settings.runtime`` (duck-typed: pipeline never imports app)."""
        fields = {name: getattr(runtime, name) for name in cls.__dataclass_fields__
                  if hasattr(runtime, name) and name not in ("grouper", "osc")}
        default = GrouperConfig()
        grouper = GrouperConfig(
            tolerance_s=getattr(runtime, "group_tolerance_s", default.tolerance_s),
            max_wait_s=getattr(runtime, "group_max_wait_s", default.max_wait_s),
            gone_after_s=getattr(runtime, "camera_gone_s", default.gone_after_s),
        )
        osc = tuple(_endpoint(v) for v in getattr(runtime, "osc", ()) or ())
        return cls(**fields, grouper=grouper, osc=osc)


def _endpoint(value: str | tuple[str, int]) -> tuple[str, int]:
    if isinstance(value, tuple):
        return value
    host, _, port = str(value).rpartition(":")
    if not host or not port.isdigit():
        raise ValueError(f"OSC destination {value!r} must be HOST:PORT")
    return host.strip("[]"), int(port)
