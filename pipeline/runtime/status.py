"""What the live pipeline reports: its status and the events for the session log.

:class:`PipelineStatus` is the one status object (issue 16, item 4): typed records, built once
per publication from the newest fused frame and the run's health
(:meth:`pipeline.runtime.board.StatusBoard.status`), pushed to the subscribers
(:mod:`pipeline.runtime.publisher`). :meth:`PipelineStatus.to_json` is its one JSON form, the
object of ``GET /api/v1/status`` and of the live WebSocket's messages; the 3D view reads the
records themselves (the skeletons' joints as arrays).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from pipeline.navigation.config import NavigationConfig, NavigationMode
from pipeline.navigation.navigators import NavigationFrame, PersonCommand
from pipeline.numbers import rounded
from pipeline.recognition.types import ActionEstimate
from pipeline.results import FrameResult, action_record
from pipeline.triangulation.types import Person3D

State = Literal["stopped", "starting", "running", "stalled", "error"]
"""``stalled``: running, but no frame fused for ``RuntimeConfig.stall_after_s`` (a worker died, the
sources went silent); back to ``running`` with the next frame."""

NUM_JOINTS = 17


@dataclass(frozen=True, slots=True)
class PipelineEvent:
    """Something for the session log.

    timestamp_s: Unix time. kind: ``state``, ``action``, ``navigator``, ``worker``, ``camera``
    (and ``adaptation``); data: the event's own fields (JSON values).
    """

    timestamp_s: float
    kind: str
    message: str
    data: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class CameraStatus:
    """One camera's health: delivering (``ok``), its frame rate, why it is not ok."""

    name: str
    ok: bool
    fps: float
    last_error: str | None = None

    def to_json(self) -> dict[str, Any]:
        return {"name": self.name, "ok": self.ok, "fps": self.fps, "last_error": self.last_error}


@dataclass(frozen=True, slots=True)
class ActionStatus:
    """A recognised command as the dashboard shows it (rounded; None where not finite).

    probs: the smoothed class probabilities. steps: the step evidence and the stepping-bout
    gate's verdict (``StepFrame.to_dict()`` + ``gate``), for the dashboard's step strip.
    """

    label: str
    confidence: float
    probs: dict[str, float]
    yaw_deg: float | None
    speed_mps: float | None
    steps: dict[str, Any] | None = None

    @classmethod
    def of(cls, a: ActionEstimate) -> ActionStatus:
        record = action_record(a)  # the per-frame results' rounding (SPEC.md)
        return cls(a.label, round(a.confidence, 4), {k: v or 0.0 for k, v in record["probs"].items()},
                   record["yaw_deg"], record["speed_mps"], record.get("steps"))

    def to_json(self) -> dict[str, Any]:
        """The navigator's ``action`` object."""
        return {"label": self.label, "probs": dict(self.probs), "yaw_deg": self.yaw_deg,
                "speed_mps": self.speed_mps, "steps": self.steps}

    def command_json(self) -> dict[str, Any]:
        """A person's own ``command`` object (each and group modes; single: the navigator's)."""
        return {"label": self.label, "confidence": self.confidence, "yaw_deg": self.yaw_deg,
                "speed_mps": self.speed_mps, "steps": self.steps}


@dataclass(frozen=True, slots=True)
class PersonStatus:
    """A person tracked in 3D now. position_m: the floor position (x, y, z), None when unknown;
    navigating: has a command of their own now (``command``)."""

    user_id: int
    position_m: tuple[float, float, float] | None
    reproj_px: float | None
    is_navigator: bool = False
    navigating: bool = False
    command: ActionStatus | None = None

    def to_json(self) -> dict[str, Any]:
        return {"user_id": self.user_id,
                "position_m": None if self.position_m is None else list(self.position_m),
                "reproj_px": self.reproj_px, "is_navigator": self.is_navigator, "navigating": self.navigating,
                "command": None if self.command is None else self.command.command_json()}


@dataclass(frozen=True, slots=True)
class Skeleton:
    """A person's 3D skeleton for the 3D view: joints_m (17, 3) float64 metres in the CAVE frame,
    NaN where unknown."""

    user_id: int
    joints_m: NDArray[np.float64]
    reproj_px: float | None

    def __post_init__(self) -> None:
        if self.joints_m.shape != (NUM_JOINTS, 3):
            raise ValueError(f"joints_m must have shape (17, 3), got {self.joints_m.shape}")

    @classmethod
    def of(cls, p: Person3D) -> Skeleton:
        joints = np.array(p.joints_m, dtype=np.float64)
        joints[~np.asarray(p.joint_valid, dtype=bool)] = np.nan
        return cls(int(p.user_id), joints, rounded(p.reproj_px, 3))

    def to_json(self) -> dict[str, Any]:
        """SPEC.md's ``people3d`` entry: ``joints`` as [x, y, z] or null, 17 of them."""
        joints = [[round(float(v), 4) for v in j] if np.all(np.isfinite(j)) else None
                  for j in self.joints_m.tolist()]
        return {"user_id": self.user_id, "joints": joints, "reproj_px": self.reproj_px}


@dataclass(frozen=True, slots=True)
class GroupStatus:
    """The room's command in group mode: a strict majority of the members, else still."""

    label: str
    confidence: float
    members: tuple[int, ...]
    votes: dict[str, int]

    def to_json(self) -> dict[str, Any]:
        return {"label": self.label, "confidence": self.confidence, "members": list(self.members),
                "votes": dict(self.votes)}


@dataclass(frozen=True, slots=True)
class NavigationStatus:
    """The navigation mode (issue 20), the chosen people (empty: everyone tracked), the group's command."""

    mode: NavigationMode = "single"
    chosen: tuple[int, ...] = ()
    group: GroupStatus | None = None

    @classmethod
    def of(cls, frame: NavigationFrame | None, config: NavigationConfig) -> NavigationStatus:
        """The frame's navigation; without one (stopped, or no 3D) the configured mode."""
        if frame is None:
            return cls(config.mode, tuple(config.user_ids))
        g = frame.group
        group = None if g is None else GroupStatus(g.action.label, round(g.confidence, 4),
                                                   tuple(int(u) for u in g.members),
                                                   {str(k): int(v) for k, v in g.votes.items()})
        return cls(frame.mode, tuple(frame.chosen), group)

    def to_json(self) -> dict[str, Any]:
        return {"mode": self.mode, "chosen": list(self.chosen),
                "group": None if self.group is None else self.group.to_json()}


@dataclass(frozen=True, slots=True)
class PipelineStatus:
    """A snapshot of the live pipeline.

    latency_ms: {stage: {"p50", "p95", "p99"}} for capture, detect, fuse, emit, end_to_end (NaN
        before any sample). dropped: frames the sources delivered that no stage processed
        (multi-view frames). people: everyone tracked in 3D, with their own commands; people3d:
        their skeletons. action: the navigator's command. frame_index: the newest fused frame's
        (-1 before the first). workstations / emitted: the UDP destinations and datagrams sent.
        held: the operator holds navigation (every locomotion command goes out ``still``; ``action``
        and ``people`` still show what the recogniser says).
        timestamp_s: Unix time the status was made.
    """

    state: State | Literal["unavailable"]
    source: str | None = None
    fps: float = 0.0
    dropped: int = 0
    processed: int = 0
    latency_ms: dict[str, dict[str, float]] = field(default_factory=dict)
    cameras: tuple[CameraStatus, ...] = ()
    people: tuple[PersonStatus, ...] = ()
    navigator: int | None = None
    navigator_mode: Literal["auto", "manual"] = "auto"
    navigation: NavigationStatus = field(default_factory=NavigationStatus)
    action: ActionStatus | None = None
    people3d: tuple[Skeleton, ...] = ()
    frame_index: int = -1
    last_error: str | None = None
    workstations: tuple[tuple[str, int], ...] = ()
    emitted: int = 0
    held: bool = False
    timestamp_s: float = field(default_factory=time.time)

    def to_json(self) -> dict[str, Any]:
        """The object of ``GET /api/v1/status`` and the live WebSocket (without the app's own fields:
        ``running_session_id``, ``active_calibration_id``, ``alarm``); 3D joints under ``extra``."""
        return {
            "state": self.state,
            "source": self.source,
            "fps": self.fps,
            "dropped": self.dropped,
            "latency_ms": {stage: {k: rounded(v, 3) for k, v in q.items()}
                           for stage, q in self.latency_ms.items()},
            "cameras": [c.to_json() for c in self.cameras],
            "people": [p.to_json() for p in self.people],
            "navigator": self.navigator,
            "navigator_mode": self.navigator_mode,
            "navigation": self.navigation.to_json(),
            "action": None if self.action is None else self.action.to_json(),
            "held": self.held,
            "ts": self.timestamp_s,
            "extra": {"people3d": [s.to_json() for s in self.people3d]} if self.people3d else {},
        }


def frame_people(result: FrameResult) -> tuple[PersonStatus, ...]:
    """The people of a fused frame: position, the navigator, each one's own command."""
    nav = result.navigation
    commands: dict[int, PersonCommand] = {c.user_id: c for c in nav.commands} if nav is not None else {}
    out = []
    for p in result.people3d:
        uid = int(p.user_id)
        x, y, z = (float(v) for v in p.position_m)
        finite = all(math.isfinite(v) for v in (x, y, z))
        command = commands.get(uid)
        out.append(PersonStatus(
            uid, (round(x, 4), round(y, 4), round(z, 4)) if finite else None, rounded(p.reproj_px, 4),
            result.navigator is not None and uid == result.navigator, command is not None,
            ActionStatus.of(command.action) if command is not None else None))
    return tuple(out)
