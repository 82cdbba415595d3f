"""What the worker processes send each other and the main process (small, picklable).

Frames never travel here: they stay in the shared-memory rings (:mod:`pipeline.runtime.shm`).
Every queue is bounded; :func:`put_latest` drops the oldest item when one is full, so a
slow consumer always gets the newest data and no backlog builds up.
"""

from __future__ import annotations

import queue
import time
from dataclasses import dataclass, field
from typing import Any, Literal

from pipeline.pose.types import ViewDetections
from pipeline.results import FrameResult
from pipeline.tracking.types import TrackedView

WorkerEventKind = Literal["started", "stopped", "error", "camera_lost", "camera_ok", "ended", "info"]
WORKER_EVENT_KINDS = ("started", "stopped", "error", "camera_lost", "camera_ok", "ended", "info")


@dataclass(frozen=True, slots=True)
class WorkerEvent:
    """A typed status report of a worker. ``stopped`` is each worker's end marker (sent in ``finally``)."""

    worker: str
    kind: WorkerEventKind
    message: str = ""
    timestamp_s: float = field(default_factory=time.time)
    pid: int = 0

    def __post_init__(self) -> None:
        if self.kind not in WORKER_EVENT_KINDS:
            raise ValueError(f"kind must be one of {WORKER_EVENT_KINDS}, got {self.kind!r}")


@dataclass(frozen=True, slots=True)
class DetectedFrame:
    """The pose stage's output for one multi-view frame.

    timestamp_s: capture time of the group (monotonic); the stamps below are monotonic too.
    missing: cameras without an image in this frame. dropped: camera frames skipped since
    the previous multi-view frame (summed over cameras, divided by the number of cameras).
    """

    frame_index: int
    timestamp_s: float
    views: tuple[ViewDetections, ...]
    detect_start_s: float
    detect_end_s: float
    missing: tuple[str, ...] = ()
    dropped: float = 0.0
    source_index: int = -1  # the sources' own frame index (counts the frames they skipped too)
    tracked: tuple[TrackedView, ...] | None = None  # when the pose stage tracked the views too


@dataclass(frozen=True, slots=True)
class FusedFrame:
    """The fusion stage's output: the frame's results and the stamps to measure latency."""

    result: FrameResult
    detected: DetectedFrame
    fuse_end_s: float
    navigator_mode: str = "auto"
    dropped_here: int = 0
    navigator_changes: tuple[Any, ...] = ()  # pipeline.triangulation.navigator.NavigatorChange
    sent_s: float | None = None  # when the fusion worker's sinks (the UDP stream) had it (monotonic)


@dataclass(frozen=True, slots=True)
class SetNavigator:
    """Control message to the fusion stage: None = automatic choice."""

    user_id: int | None


@dataclass(frozen=True, slots=True)
class SetAdaptation:
    """Control message to the fusion stage: a participant's teach adaptation (None: none)."""

    adaptation: Any


@dataclass(frozen=True, slots=True)
class SetNavigation:
    """Control message to the fusion stage: the navigation mode and its chosen people (issue 20)."""

    mode: str
    user_ids: tuple[int, ...] = ()


@dataclass(frozen=True, slots=True)
class SendPrompt:
    """Control message to the fusion stage: one ``prompt`` datagram on its stream."""

    text: str
    label: str
    remaining_s: float


def put_latest(q: Any, item: object, retries: int = 3) -> int:
    """Put without blocking; when the queue is full drop the oldest first. Returns how many were dropped."""
    dropped = 0
    for _ in range(retries):
        try:
            q.put_nowait(item)
            return dropped
        except queue.Full:
            try:  # a short wait: the oldest item may still be in the feeder thread, not the pipe
                q.get(timeout=0.05)
                dropped += 1
            except queue.Empty:
                pass
    return dropped + 1  # the item itself could not be queued


def drain_latest(q: Any, first: object) -> tuple[object, int]:
    """The newest item waiting in ``q`` (``first`` if none), and how many older ones were skipped."""
    item, skipped = first, 0
    while True:
        try:
            item = q.get_nowait()
            skipped += 1
        except queue.Empty:
            return item, skipped
