"""One run of the live pipeline: its worker processes' queues and rings, its cameras' health,
its newest result and its counters (plain state, shared by the launcher, the result router
and the status board)."""

from __future__ import annotations

import threading
from dataclasses import dataclass, field
from typing import Any, Protocol

from pipeline.camera import Camera
from pipeline.runtime.mailbox import Mailbox
from pipeline.runtime.messages import FusedFrame
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.shm import FrameRing
from pipeline.runtime.supervisor import Supervisor
from pipeline.takes.video import VideoControl


class SimFactory(Protocol):
    """Builds the simulator inside its worker; tells the main process its virtual cameras."""

    @property
    def cameras(self) -> tuple[Camera, ...]: ...

    @property
    def fps(self) -> float: ...

    def __call__(self) -> Any: ...


@dataclass
class RunCamera:
    """A camera of the run and its health (``ring`` None: a virtual camera of the simulator)."""

    name: str
    ring: FrameRing | None = None
    ok: bool = False
    fps: float = 0.0
    last_error: str | None = None
    ended: bool = False
    last_seq: int = -1
    last_sample_s: float = 0.0
    last_index: int = -1
    first_index: int | None = None
    video: VideoControl | None = None  # the take's video of this camera (pipeline/takes/video.py)
    capture_fps: float = 0.0  # the rate its worker captures at (the video's)


@dataclass
class Run:
    """The processes, queues and counters of one start."""

    source: str
    cameras: dict[str, RunCamera]
    events_q: Any
    supervisor: Supervisor
    out_box: Mailbox | None = None  # fusion -> the collector
    det_box: Mailbox | None = None  # detect/simulator -> fusion
    control_q: Any = None
    stop: threading.Event = field(default_factory=threading.Event)
    threads: list[threading.Thread] = field(default_factory=list)
    metrics: RuntimeMetrics = field(default_factory=RuntimeMetrics)
    first_source_index: int | None = None
    produced_before: int = 0
    last_source_index: int = -1
    latest: FusedFrame | None = None
    last_result_s: float = 0.0  # time.monotonic() of the newest fused frame

    def count_source_index(self, index: int) -> None:
        """Account a result's source frame index (a source that restarts from 0 is added up)."""
        if self.first_source_index is None:
            self.first_source_index = index
        elif index + 5 < self.last_source_index:  # the source restarted from frame 0
            self.produced_before += self.last_source_index - self.first_source_index + 1
            self.first_source_index = index
            self.last_source_index = index
        self.last_source_index = max(self.last_source_index, index)

    @property
    def produced(self) -> int:
        """Frames the sources delivered (multi-view frames)."""
        return self.produced_before + (self.last_source_index - self.first_source_index + 1
                                       if self.first_source_index is not None else 0)
