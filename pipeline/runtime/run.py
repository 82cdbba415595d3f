"""One run of the live pipeline: its worker processes' queues and rings, its cameras' health,
its newest result and its counters (plain state, shared by the launcher, the result router
and the status board)."""

from __future__ import annotations

import math
import multiprocessing.queues as mpq
import threading
from collections.abc import Iterable
from dataclasses import dataclass, field

from pipeline.navigation.config import TRACKED_WITHIN_S
from pipeline.runtime.mailbox import Mailbox
from pipeline.runtime.messages import ControlMessage, FusedFrame, WorkerEvent
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.shm import FrameRing
from pipeline.runtime.supervisor import Supervisor
from pipeline.takes.video import VideoControl
from pipeline.triangulation.types import Person3D


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
    events_q: mpq.Queue[WorkerEvent] | None
    supervisor: Supervisor
    out_box: Mailbox | None = None  # fusion -> the collector
    det_box: Mailbox | None = None  # detect/simulator -> fusion
    control_q: mpq.Queue[ControlMessage] | None = None  # the fusion worker's (new for each fusion worker)
    stop: threading.Event = field(default_factory=threading.Event)
    threads: list[threading.Thread] = field(default_factory=list)
    metrics: RuntimeMetrics = field(default_factory=RuntimeMetrics)
    first_source_index: int | None = None
    produced_before: int = 0
    last_source_index: int = -1
    latest: FusedFrame | None = None
    last_result_s: float = 0.0  # time.monotonic() of the newest fused frame
    seen_s: dict[int, float] = field(default_factory=dict)  # user id -> time.monotonic() last fused
    max_user_id: int = 0  # the highest user id fused in this run (0: none yet)
    numbered_from: int | None = None  # the first user id of a fusion worker started again in the run
    xy_m: dict[int, tuple[float, float]] = field(default_factory=dict)  # user id -> floor position last fused

    def note_people(self, people: Iterable[Person3D], now_s: float) -> None:
        """The people of a fused frame, and where they stand; those not seen for an hour are forgotten."""
        for person in people:
            uid = person.user_id
            self.seen_s[uid] = now_s
            self.max_user_id = max(self.max_user_id, uid)
            x, y = float(person.position_m[0]), float(person.position_m[1])
            if math.isfinite(x) and math.isfinite(y):
                self.xy_m[uid] = (x, y)
        if len(self.seen_s) > 64:
            for uid in [u for u, t in self.seen_s.items() if now_s - t > 3600.0]:
                del self.seen_s[uid]
                self.xy_m.pop(uid, None)

    def operator_navigator(self) -> tuple[int, tuple[float, float]] | None:
        """The navigator the operator chose (the newest fused frame's, in manual mode) and where they
        were last fused; None in the automatic choice or before they were ever placed."""
        latest = self.latest
        if latest is None or latest.navigator_mode != "manual" or latest.result.navigator is None:
            return None
        uid = latest.result.navigator
        return (uid, self.xy_m[uid]) if uid in self.xy_m else None

    def tracked(self, now_s: float, within_s: float = TRACKED_WITHIN_S) -> list[int]:
        """The user ids fused within the last ``within_s`` seconds. A person the tracker misses
        for a frame or two (one view occluded, a frame that did not triangulate) is still
        tracked: an operator's choice of them must not fail on that frame."""
        return sorted(u for u, t in self.seen_s.items() if now_s - t <= within_s)

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
