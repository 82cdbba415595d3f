"""What the live pipeline reports: its status snapshot and the events for the session log."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

State = Literal["stopped", "starting", "running", "stalled", "error"]
"""``stalled``: running, but no frame fused for ``RuntimeConfig.stall_after_s`` (a worker died, the
sources went silent); back to ``running`` with the next frame."""


@dataclass(frozen=True, slots=True)
class PipelineEvent:
    """Something for the session log.

    timestamp_s: Unix time. kind: ``state``, ``action``, ``navigator``, ``worker`` or ``camera``.
    """

    timestamp_s: float
    kind: str
    message: str
    data: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class PipelineStatus:
    """A snapshot of the live pipeline (plain values, ready for JSON).

    latency_ms: {stage: {"p50", "p95", "p99"}} for capture, detect, fuse, emit, end_to_end.
    cameras: [{"name", "ok", "fps", "last_error"}]. people: [{"user_id", "position_m", "reproj_px"}].
    action: {"label", "probs", "yaw_deg", "speed_mps"} or None.
    people3d: [{"user_id", "joints": [[x, y, z] or None] x 17, "reproj_px"}] for the 3D view.
    dropped: frames the sources delivered that no stage processed (multi-view frames).
    navigation: {"mode", "chosen", "commands": [{"user_id", "action", "confidence", "action_record"}],
        "group"} (issue 20; :func:`pipeline.navigation.views.navigation_record`).
    """

    state: State
    source: str | None
    fps: float
    dropped: int
    processed: int
    latency_ms: dict[str, dict[str, float]]
    cameras: tuple[dict[str, Any], ...]
    people: tuple[dict[str, Any], ...]
    navigator: int | None
    navigator_mode: str
    action: dict[str, Any] | None
    people3d: tuple[dict[str, Any], ...]
    frame_index: int
    last_error: str | None = None
    workstations: tuple[tuple[str, int], ...] = ()
    emitted: int = 0
    navigation: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        return {name: getattr(self, name) for name in self.__dataclass_fields__}
