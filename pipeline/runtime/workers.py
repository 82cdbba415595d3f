"""The worker processes' main functions: capture, pose detection, fusion, simulator.

Each runs inside :func:`worker_main`, which names the process ``cw-<worker>`` (in
``/proc/PID/comm``, for ps and top), ignores SIGINT (the main process decides when to
stop), catches any error at the loop boundary and reports it as a typed
:class:`WorkerEvent`, and always sends a ``stopped`` event (the end marker) in
``finally``. SIGTERM ends the loop and the worker exits with :data:`SIGTERM_EXIT`.

Every loop also ends when the main process disappears (its pipe closes; checked every
:data:`PARENT_CHECK_S`): the worker then unlinks the shared-memory rings it attached
(the main process can no longer do it) and exits at once, without waiting on queues
nobody reads any more, so no worker and no segment outlives a killed main process.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import logging
import multiprocessing
import os
import queue as _queue
import signal
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from pipeline.errors import CavewalkError, SourceError
from pipeline.runtime.chain import ChainConfig, build_detector, build_fusion, build_pose_stage
from pipeline.runtime.logfile import LOG_FORMAT, LogFileConfig, log_to_file
from pipeline.runtime.mailbox import Mailbox, MailboxSpec
from pipeline.runtime.messages import (
    BoundedQueue,
    ControlChannel,
    ControlMessage,
    DetectedFrame,
    FusedFrame,
    NumberFrom,
    ResumeNavigator,
    SendPrompt,
    SetAdaptation,
    SetNavigation,
    SetNavigator,
    TrackedFrame,
    WorkerEvent,
    WorkerEventKind,
    put_latest,
)
from pipeline.runtime.metrics import AdaptiveRate, ema
from pipeline.runtime.shm import FrameRing, RingSpec, unlink_attached
from pipeline.runtime.sinks import StreamSink, StreamSpec
from pipeline.runtime.stages import Fusion
from pipeline.sources import open_source
from pipeline.sources.grouper import FrameRef, GrouperConfig, MultiViewGrouper
from pipeline.sources.opencv import Pacer
from pipeline.takes.video import VideoControl, VideoTap

log = logging.getLogger(__name__)

POLL_S = 0.002  # how often an idle stage looks for new input
PARENT_CHECK_S = 0.25  # how often a worker checks that the main process still runs
SIGTERM_EXIT = 143  # a worker's exit status after SIGTERM (128 + 15, as a shell reports it)
_PR_SET_NAME = 15


@dataclass(frozen=True, slots=True)
class CaptureSpec:
    """One camera's capture worker: what to open and how to pace it."""

    camera: str
    uri: str
    pace_fps: float | None = None
    loop: bool = False
    start_s: float | None = None
    retry_s: float = 1.0
    nice: int = 0  # added to the worker's niceness (decoding gives way to detection)


@dataclass(frozen=True, slots=True)
class DetectSpec:
    cameras: tuple[str, ...]
    target_fps: float
    grouper: GrouperConfig = field(default_factory=GrouperConfig)


class StopFlag(Protocol):
    """The run's stop flag (a ``multiprocessing`` event)."""

    def is_set(self) -> bool: ...

    def wait(self, timeout: float | None = None) -> bool: ...


class _Ctx:
    """What every worker loop needs: its name, the event queue, the stop flag, the parent's pid."""

    def __init__(self, name: str, events: BoundedQueue[WorkerEvent], stop: StopFlag, parent_pid: int) -> None:
        self.name = name
        self.events = events
        self.stop = stop
        self.parent_pid = parent_pid
        self.terminated = False
        self._parent = multiprocessing.parent_process()
        self._parent_checked = 0.0
        self._parent_alive = True

    def parent_alive(self) -> bool:
        """Whether the main process still runs (checked at most every 0.25 s)."""
        now = time.monotonic()
        if now - self._parent_checked > PARENT_CHECK_S:
            self._parent_checked = now
            if self._parent is not None:
                self._parent_alive = self._parent.is_alive()
            else:
                self._parent_alive = _pid_alive(self.parent_pid)
        return self._parent_alive

    def running(self) -> bool:
        return not self.terminated and not self.stop.is_set() and self.parent_alive()

    def report(self, kind: WorkerEventKind, message: str = "") -> None:
        put_latest(self.events, WorkerEvent(self.name, kind, message, time.time(), os.getpid()))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def worker_main(name: str, body: Callable[..., None], events: BoundedQueue[WorkerEvent], stop: StopFlag,
                parent_pid: int, *args: object, log: LogFileConfig | None = None) -> None:
    """Process entry point: run ``body(ctx, *args)`` with the error/end-marker discipline; the log
    goes to stderr and to the server's log file (``log``, when it names one)."""
    ctx = _Ctx(name, events, stop, parent_pid)
    set_process_name(f"cw-{name}")
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda *_: setattr(ctx, "terminated", True))
    logging.basicConfig(level=logging.INFO, format=LOG_FORMAT, datefmt="%H:%M:%S")
    if log is not None:
        try:
            log_to_file(log, rotate=False)
        except OSError as exc:  # the app's process opened it; a worker goes on without it
            logging.getLogger(__name__).warning("cannot write the log file %s: %s", log.path, exc)
    ctx.report("started")
    code = 0
    try:
        body(ctx, *args)
    except CavewalkError as exc:
        ctx.report("error", str(exc))
        code = 1
    except Exception as exc:  # the loop boundary: report, never die silently
        ctx.report("error", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}")
        code = 1
    finally:
        if not ctx.parent_alive():  # orphaned: clean up what the main process cannot, and go
            unlink_attached()
            logging.shutdown()
            os._exit(code)
        ctx.report("stopped", "terminated (SIGTERM)" if ctx.terminated else "")
        time.sleep(0.05)  # let the queue's feeder thread flush the end marker
    if ctx.terminated:
        code = code or SIGTERM_EXIT
    if code:
        raise SystemExit(code)


def set_process_name(name: str) -> None:
    """The process's name in /proc/PID/comm (15 bytes; Linux only, silently nothing elsewhere)."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.prctl(_PR_SET_NAME, ctypes.c_char_p(name.encode()[:15]), 0, 0, 0)
    except (OSError, AttributeError):
        pass


# ------------------------------------------------------------------------------------ capture
def capture_loop(ctx: _Ctx, spec: CaptureSpec, ring_spec: RingSpec,
                 video: VideoControl | None = None) -> None:
    """Open the camera, copy its frames into the ring; retry a camera that fails or vanishes.

    Frames the detector will not look at (it said when it next will, in the ring's
    header) are grabbed but not converted or copied: the dynamic frame rate saves the
    capture work too. Video files hand over their decoder's I420 frames (half the bytes
    of BGR, and no conversion of the whole frame; the detector converts its crops).
    While a take records this camera's video (``video``, :mod:`pipeline.takes.video`),
    every frame is converted and handed to its encoder thread, which never holds up the loop.
    """
    if spec.nice:
        try:
            os.nice(spec.nice)
        except OSError as exc:  # not allowed here: run at the normal priority
            log.warning("camera %s: cannot lower the capture priority (%s)", spec.camera, exc)
    ring = FrameRing.attach(ring_spec)
    claimed: list[NDArray[np.uint8]] = []

    def into_ring(shape: tuple[int, ...]) -> NDArray[np.uint8]:
        claimed.append(ring.claim(shape))
        return claimed[-1]

    tap = VideoTap(video, spec.camera) if video is not None else None
    lost = False
    try:
        while ctx.running():
            try:
                source = open_source(spec.uri, spec.camera, pace_fps=spec.pace_fps, loop=spec.loop,
                                     start_s=spec.start_s, native=True)
            except SourceError as exc:
                if not lost:
                    ctx.report("camera_lost", str(exc))
                    lost = True
                ctx.stop.wait(spec.retry_s)
                continue
            slack_s = 1.5 / (spec.pace_fps or source.nominal_fps or 30.0)
            try:
                while ctx.running():
                    if not source.grab():
                        ctx.report("ended", f"camera {spec.camera}: source ended")
                        return
                    if lost:
                        ctx.report("camera_ok", f"camera {spec.camera} delivers again")
                        lost = False
                    taping = tap is not None and tap.active()
                    if time.monotonic() < ring.demand_s - slack_s:
                        if tap is not None and taping:  # only the video wants it: into its own buffer
                            own = source.retrieve()
                            if own is not None:
                                tap.offer(own.image, own.timestamp_s, owned=True)
                        continue  # the detector will not look before then: skip the conversion
                    claimed.clear()
                    frame = source.retrieve(into_ring)  # decoded straight into the ring's next slot
                    if frame is not None:
                        if claimed and frame.image is claimed[-1]:
                            ring.publish(frame.image.shape, frame.timestamp_s, frame.index)
                        else:
                            ring.write(frame.image, frame.timestamp_s, frame.index)
                        if tap is not None and taping:
                            tap.offer(frame.image, frame.timestamp_s)
            except SourceError as exc:
                ctx.report("camera_lost", str(exc))
                lost = True
                ctx.stop.wait(spec.retry_s)
            finally:
                source.close()
    finally:
        if tap is not None:
            tap.close()
        ring.close()


# ------------------------------------------------------------------------------------- detect
def detect_loop(ctx: _Ctx, spec: DetectSpec, ring_specs: tuple[RingSpec, ...], chain: ChainConfig,
                out_box: MailboxSpec) -> None:
    """Group the newest frames of the cameras, detect and track the people in them (the chain's
    pose stage, the pose model in one batch), hand on."""
    rings = {cam: FrameRing.attach(rs) for cam, rs in zip(spec.cameras, ring_specs, strict=True)}
    out = Mailbox.attach(out_box)
    try:
        stage = build_pose_stage(chain)
        grouper = MultiViewGrouper(list(spec.cameras), spec.grouper)
        rate = AdaptiveRate(spec.target_fps)
        busy: float | None = None
        next_at = 0.0
        frame_index = 0
        buffers: dict[str, NDArray[np.uint8]] = {}  # per camera: frames are copied into these
        while ctx.running():
            now = time.monotonic()
            for cam, ring in rings.items():
                seq = ring.latest_seq
                if seq >= 0:
                    ts = ring.timestamp_of(seq)  # the header only; pixels are copied for the group
                    if ts is not None:
                        grouper.offer(FrameRef(cam, seq, ts), now)
            if now < next_at:
                ctx.stop.wait(min(POLL_S, next_at - now))
                continue
            group = grouper.poll(now)
            if group is None:
                ctx.stop.wait(POLL_S)
                continue
            images, cams, stamps, indices = [], [], [], []
            for m in group.members:
                ring = rings[m.camera]
                buf = buffers.get(m.camera)
                if buf is None:
                    buf = buffers[m.camera] = np.empty(ring.spec.capacity_bytes, np.uint8)
                slot = ring.read_seq(m.seq, buf) or ring.read_latest(m.seq - 1, buf)
                if slot is not None:
                    images.append(slot.image)
                    cams.append(m.camera)
                    stamps.append(slot.timestamp_s)
                    indices.append(slot.index)
            if not images:
                continue
            t0 = time.monotonic()
            tracked, _ = stage.detect(images, cams, frame_index, min(stamps))
            t1 = time.monotonic()
            busy = ema(busy, t1 - t0)
            next_at = now + rate.period_s(busy)  # from when this group was taken, reading included
            for ring in rings.values():  # the dynamic frame rate reaches back to the cameras
                ring.set_demand(next_at)
            dropped = sum(group.skipped.values()) / max(1, len(spec.cameras))
            missing = tuple(c for c in spec.cameras if c not in cams)
            detected = DetectedFrame(frame_index, min(stamps), tuple(t.detections for t in tracked), t0, t1,
                                     missing, dropped, max(indices))
            out.put(TrackedFrame(detected, tracked))
            frame_index += 1
    finally:
        out.close()
        for ring in rings.values():
            ring.close()


# ------------------------------------------------------------------------------------- fusion
def fuse_loop(ctx: _Ctx, chain: ChainConfig, in_box: MailboxSpec, out_box: MailboxSpec,
              control: ControlChannel, stream: StreamSpec | None = None) -> None:
    """Triangulation, navigator and recognition (the chain's fusion) on the newest tracked frame;
    the result goes to the UDP stream at once (``stream``), then to the main process."""
    fusion = build_fusion(chain)
    inbox, out = Mailbox.attach(in_box), Mailbox.attach(out_box)
    sink = StreamSink.open(stream) if stream is not None else None
    try:
        for msg in control.first:
            _apply(ctx, fusion, msg, sink)
        _fuse(ctx, fusion, inbox, out, control.queue, sink)
    finally:
        if sink is not None:
            sink.close()
        inbox.close()
        out.close()


def _fuse(ctx: _Ctx, fusion: Fusion, inbox: Mailbox, out: Mailbox, control_q: BoundedQueue[ControlMessage],
          sink: StreamSink | None) -> None:
    while ctx.running():
        _control(ctx, fusion, control_q, sink)
        got = inbox.get(timeout=0.05)
        if sink is not None:
            sink.check(time.monotonic())
        if got is None:
            continue
        item, skipped = got
        if not isinstance(item, TrackedFrame):
            continue
        result = fusion.update(item)
        fused_s = time.monotonic()
        sent_s = None
        if sink is not None:
            sink.on_result(result)
            sent_s = time.monotonic()
        out.put(FusedFrame(result, item.detected, fused_s, fusion.mode, skipped, fusion.take_changes(),
                           sent_s))


def _control(ctx: _Ctx, fusion: Fusion, control_q: BoundedQueue[ControlMessage],
             sink: StreamSink | None) -> None:
    while True:
        try:
            msg = control_q.get_nowait()
        except _queue.Empty:
            return
        _apply(ctx, fusion, msg, sink)


def _apply(ctx: _Ctx, fusion: Fusion, msg: ControlMessage, sink: StreamSink | None) -> None:
    if isinstance(msg, SetNavigator):
        try:
            fusion.set_navigator(msg.user_id)
        except CavewalkError as exc:  # the user left between the request and now
            ctx.report("info", f"navigator not changed: {exc}")
    elif isinstance(msg, SetNavigation):
        try:
            fusion.set_navigation(msg.mode, msg.user_ids)
        except CavewalkError as exc:
            ctx.report("info", f"navigation mode not changed: {exc}")
    elif isinstance(msg, SendPrompt) and sink is not None:
        sink.send_prompt(msg.text, msg.label, msg.remaining_s)
    elif isinstance(msg, SetAdaptation):
        fusion.set_adaptation(msg.adaptation)
    elif isinstance(msg, NumberFrom):
        fusion.number_from(msg.first_user_id)
    elif isinstance(msg, ResumeNavigator):
        fusion.resume_navigator(msg.user_id, msg.xy_m)


# ---------------------------------------------------------------------------------- simulator
def sim_loop(ctx: _Ctx, chain: ChainConfig, out_box: MailboxSpec) -> None:
    """The simulator in place of capture and the pose model: its virtual cameras' detections (the
    chain's detector), tracked by the chain's pose stage, paced at the simulator's rate."""
    detector, stage = build_detector(chain), build_pose_stage(chain)
    out = Mailbox.attach(out_box)
    pacer = Pacer(detector.fps)
    frame_index = 0
    while ctx.running():
        pacer.wait_for(frame_index)
        t0 = time.monotonic()
        views = detector.detect(frame_index, t0)
        tracked = stage.track(views)
        t1 = time.monotonic()
        detected = DetectedFrame(frame_index, t0, views, t0, t1, source_index=frame_index)
        out.put(TrackedFrame(detected, tracked))
        frame_index += 1
        due = pacer.due_slot(time.monotonic())
        if due > frame_index:  # fell behind: skip, never build a backlog
            frame_index = due
