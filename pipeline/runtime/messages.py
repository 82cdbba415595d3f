"""What the worker processes send each other and the main process (small, picklable).

Frames never travel here: they stay in the shared-memory rings (:mod:`pipeline.runtime.shm`).
Every queue is bounded; :func:`put_latest` drops the oldest item when one is full, so a
slow consumer always gets the newest data and no backlog builds up.
"""

from __future__ import annotations

import queue
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, Protocol, TypeVar

from pipeline.pose.types import ViewDetections
from pipeline.results import FrameResult
from pipeline.tracking.types import TrackedView

if TYPE_CHECKING:
    from pipeline.takes.teach import OutputAdaptation
    from pipeline.triangulation.navigator import NavigatorChange

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
    """What a detector found in one multi-view frame: the pose model in camera images, or the
    simulator's virtual cameras (:class:`pipeline.runtime.stages.SimDetector`).

    views: each view's detections, not tracked yet (the pose stage tracks them).
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


@dataclass(frozen=True, slots=True)
class TrackedFrame:
    """The pose stage's output, fusion's input: a detected frame with each view's people tracked.

    views: one per view of ``detected``, in the same order; ``views[i].detections`` is
    ``detected.views[i]``.
    """

    detected: DetectedFrame
    views: tuple[TrackedView, ...]

    def __post_init__(self) -> None:
        got = tuple(v.camera for v in self.views)
        want = tuple(v.camera for v in self.detected.views)
        if got != want:
            raise ValueError(f"tracked views {list(got)} do not match the detected views {list(want)}")

    @property
    def frame_index(self) -> int:
        return self.detected.frame_index

    @property
    def timestamp_s(self) -> float:
        return self.detected.timestamp_s


@dataclass(frozen=True, slots=True)
class FusedFrame:
    """The fusion stage's output: the frame's results and the stamps to measure latency."""

    result: FrameResult
    detected: DetectedFrame
    fuse_end_s: float
    navigator_mode: str = "auto"
    dropped_here: int = 0
    navigator_changes: tuple[NavigatorChange, ...] = ()
    sent_s: float | None = None  # when the fusion worker's sinks (the UDP stream) had it (monotonic)


@dataclass(frozen=True, slots=True)
class SetNavigator:
    """Control message to the fusion stage: None = automatic choice."""

    user_id: int | None


@dataclass(frozen=True, slots=True)
class SetAdaptation:
    """Control message to the fusion stage: a participant's teach adaptation (None: none)."""

    adaptation: OutputAdaptation | None


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


@dataclass(frozen=True, slots=True)
class NumberFrom:
    """Control message to a fusion worker started again in a run: number the people it finds from
    ``first_user_id`` on, past every id its predecessor gave out, so that an operator's choice of
    a user id (a navigator, the chosen people of a mode) never falls on somebody else."""

    first_user_id: int


@dataclass(frozen=True, slots=True)
class ResumeNavigator:
    """Control message to a fusion worker started again in a run, or to a new run's first one (a
    restart, a rebuilt pipeline): the operator had chosen the navigator ``user_id`` (of the worker
    or run before), last seen at ``xy_m``; the person tracked anew there is the navigator again
    (the selector's re-acquisition), else the choice falls back to the automatic one as for a
    navigator lost."""

    user_id: int
    xy_m: tuple[float, float]


ControlMessage = SetNavigator | SetAdaptation | SetNavigation | SendPrompt | NumberFrom | ResumeNavigator
"""What the main process tells a running fusion worker (its control queue)."""


T = TypeVar("T")


class BoundedQueue(Protocol[T]):
    """A bounded queue of ``T`` (``multiprocessing`` or ``queue``), as :func:`put_latest` uses it."""

    def put_nowait(self, item: T, /) -> None: ...

    def get(self, block: bool = True, timeout: float | None = None) -> T: ...

    def get_nowait(self) -> T: ...


@dataclass(frozen=True, slots=True)
class ControlChannel:
    """A fusion worker's control: ``queue`` (the main process puts into it while the worker runs)
    and ``first``, the messages the worker applies before its first frame. A worker started again
    in a run gets the run's state that way: a message put into a new queue may still be in its
    feeder thread when the worker reads it, and the first frames would go out without it."""

    queue: BoundedQueue[ControlMessage]
    first: tuple[ControlMessage, ...] = ()


def put_latest(q: BoundedQueue[T], item: T, retries: int = 3) -> int:
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


def drain_latest(q: BoundedQueue[T], first: T) -> tuple[T, int]:
    """The newest item waiting in ``q`` (``first`` if none), and how many older ones were skipped."""
    item, skipped = first, 0
    while True:
        try:
            item = q.get_nowait()
            skipped += 1
        except queue.Empty:
            return item, skipped
