"""The launcher and the supervision of a run: worker processes, their queues and rings.

:class:`Launcher` builds a :class:`~pipeline.runtime.run.Run` from a plan (the simulator's
chain, or a capture worker per camera and the detect + fuse chain), hands its groups to a
:class:`~pipeline.runtime.supervisor.Supervisor`, and tears it down again (every worker
stopped, every queue, mailbox and ring freed). :class:`Supervision` is the body of the
run's supervision thread: worker events, restarts, camera health and the stall check.
"""

from __future__ import annotations

import logging
import multiprocessing as mp
import multiprocessing.queues as mpq
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.context import BaseContext
from pathlib import Path

from pipeline.camera import Camera
from pipeline.errors import SourceError
from pipeline.runtime.board import StatusBoard
from pipeline.runtime.chain import ChainConfig, PoseModel, SimWorldFactory
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.mailbox import Mailbox
from pipeline.runtime.messages import (
    ControlChannel,
    ControlMessage,
    NumberFrom,
    ResumeNavigator,
    SetAdaptation,
    SetNavigation,
    T,
    WorkerEvent,
)
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.plan import slot_bytes
from pipeline.runtime.run import Run, RunCamera
from pipeline.runtime.shm import FrameRing, RingSpec
from pipeline.runtime.sinks import StreamSpec
from pipeline.runtime.supervisor import PerSpawn, Supervisor, WorkerDef, drain
from pipeline.runtime.workers import CaptureSpec, DetectSpec, capture_loop, detect_loop, fuse_loop, sim_loop
from pipeline.sources import source_kind
from pipeline.sources.opencv import probe_video
from pipeline.takes.video import VideoControl

log = logging.getLogger(__name__)

# imported once by the fork server, so a worker (re)started from it runs at once
FORKSERVER_PRELOAD = ["numpy", "cv2", "pipeline.runtime.workers", "pipeline.runtime.chain",
                      "pipeline.triangulation.reconstructor", "pipeline.triangulation.navigator"]


@dataclass(frozen=True)
class ChainParts:
    """What a run's chain is built from (the pipeline's parts at the time of the start): the chain's
    stages, and the detectors it may run on (the pose model for images, the simulator)."""

    chain: ChainConfig
    stream: StreamSpec
    cameras_calibrated: tuple[Camera, ...] | None
    pose: PoseModel | None
    simulator: SimWorldFactory | None
    #: the pipeline's chain now: its navigation mode and teach adaptation, changed while the run goes
    #: on, reach a fusion worker started later in the run (``chain`` holds those of the start)
    current: Callable[[], ChainConfig]
    #: the first user id of the run: past those of the pipeline's earlier runs, so that a choice of
    #: people kept from an earlier run (the navigation mode's) is nobody in this one
    first_user_id: int = 1
    #: the navigator the operator chose by hand in the run this one replaces (a restart), and where
    #: they stood: looked for there by the run's first fusion worker (None: the automatic choice)
    resume_navigator: tuple[int, tuple[float, float]] | None = None


class Launcher:
    """Starts the worker processes of a run and frees them again."""

    def __init__(self, config: RuntimeConfig) -> None:
        self.config = config

    def launch(self, source: str, plan: dict[str, str], parts: ChainParts) -> Run:
        """A run with its workers started (its threads not yet); on error nothing is left running."""
        ctx = mp.get_context(self.config.start_method)
        if self.config.start_method == "forkserver":
            ctx.set_forkserver_preload(FORKSERVER_PRELOAD)
        events_q = ctx.Queue(maxsize=1000)
        run = Run(source=source, cameras={}, events_q=events_q,
                  supervisor=Supervisor(ctx, events_q, log=self.config.log),
                  metrics=RuntimeMetrics(self.config.latency_window))
        try:
            if source == "simulator":
                self._launch_sim(ctx, run, parts)
            else:
                self._launch_images(ctx, run, plan, parts)
        except BaseException:
            self.teardown(run)
            raise
        return run

    def _launch_sim(self, ctx: BaseContext, run: Run, parts: ChainParts) -> None:
        sim = parts.simulator
        if sim is None:
            raise SourceError("the simulator is not available in this pipeline")
        run.cameras = {c.name: RunCamera(c.name, ok=True) for c in sim.cameras}
        chain = parts.chain.on_simulator(sim)
        run.det_box, run.out_box = Mailbox.create("det"), Mailbox.create("fused")
        det, out, stream = run.det_box.spec, run.out_box.spec, parts.stream

        def build_sim() -> list[WorkerDef]:
            return [("simulator", sim_loop, (chain, det)),
                    ("fuse", fuse_loop, (chain, det, out, _control(ctx, run, parts), stream))]

        run.supervisor.add_group("chain", build_sim)

    def _launch_images(self, ctx: BaseContext, run: Run, plan: dict[str, str], parts: ChainParts) -> None:
        if parts.pose is None:
            raise SourceError("no pose detector configured for image sources")
        names = tuple(plan)
        start_s = time.monotonic() + 0.5  # one trigger for every file source: they stay in step
        for name, uri in plan.items():
            self._launch_capture(ctx, run, name, uri, start_s)
        calibrated = None
        if parts.cameras_calibrated is not None:
            calibrated = tuple(c for c in parts.cameras_calibrated if c.name in plan)
            if len(calibrated) < 2:
                calibrated = None
        chain = parts.chain.with_views(parts.pose, names, calibrated)
        dspec = DetectSpec(names, self.config.target_fps, self.config.grouper)
        rings = tuple(run.cameras[n].ring.spec for n in names)  # type: ignore[union-attr]
        run.det_box, run.out_box = Mailbox.create("det"), Mailbox.create("fused")
        det, out, stream = run.det_box.spec, run.out_box.spec, parts.stream

        def build_workers() -> list[WorkerDef]:
            return [("detect", detect_loop, (dspec, rings, chain, det)),
                    ("fuse", fuse_loop, (chain, det, out, _control(ctx, run, parts), stream))]

        run.supervisor.add_group("chain", build_workers)

    def _launch_capture(self, ctx: BaseContext, run: Run, name: str, uri: str, start_s: float) -> None:
        kind = source_kind(uri)
        pace = self.config.video_pace_fps
        capacity, native_fps = self.config.max_frame_bytes, 30.0
        if kind == "video":
            (w, h), fps = probe_video(name, Path(uri))
            capacity, native_fps = slot_bytes(w, h), fps or 30.0
        ring = FrameRing.create(self.config.ring_slots, capacity, name)
        file_like = kind in ("video", "folder")
        pace_fps = (None if pace == 0 else pace or native_fps) if file_like else None
        run.cameras[name] = cam = RunCamera(name, ring, video=VideoControl.create(ctx),
                                            capture_fps=pace_fps or native_fps)
        spec = CaptureSpec(name, uri, pace_fps=pace_fps, loop=self.config.video_loop if file_like else False,
                           start_s=start_s, retry_s=self.config.camera_retry_s, nice=self.config.capture_nice)
        run.supervisor.add_group(f"capture-{name}", _capture_group(spec, ring.spec, cam.video))

    def teardown(self, run: Run) -> None:
        """Stop every worker and thread of the run; free its queues, mailboxes and rings."""
        run.stop.set()
        run.supervisor.stop()
        for t in run.threads:
            if t is not threading.current_thread():
                t.join(timeout=2.0)
        _release(run.control_q)
        _release(run.events_q)
        for box in (run.det_box, run.out_box):
            if box is not None:
                box.unlink()
        run.det_box = run.out_box = None
        for cam in run.cameras.values():
            if cam.ring is not None:
                cam.ring.unlink()
                cam.ring = None
        # queues and events hold named semaphores (in /dev/shm under forkserver) until collected
        run.control_q = run.events_q = None
        run.threads = []
        run.latest = None


class Supervision:
    """The run's supervision thread: worker events, restarts, camera health, the stall check."""

    def __init__(self, config: RuntimeConfig, board: StatusBoard) -> None:
        self.config = config
        self._board = board

    def watch(self, run: Run) -> None:
        """The thread's body: until the run stops."""
        while not run.stop.is_set():
            for ev in drain(run.events_q):
                if isinstance(ev, WorkerEvent):
                    run.supervisor.note_event(ev)
                    self.on_worker_event(run, ev)
            for ev in run.supervisor.check():
                self.on_worker_event(run, ev)
            self.sample_cameras(run)
            self.check_stall(run)
            run.stop.wait(0.05)

    def check_stall(self, run: Run) -> None:
        """``running`` -> ``stalled`` when no frame was fused for ``stall_after_s`` (heartbeats say so)."""
        gone = time.monotonic() - run.last_result_s
        if gone > self.config.stall_after_s:
            self._board.transition(run, "stalled", ("running",), f"stalled (no frame for {gone:.1f} s)",
                                   {"state": "stalled", "source": run.source})

    def on_worker_event(self, run: Run, ev: WorkerEvent) -> None:
        cam_name = ev.worker.removeprefix("capture-")
        cam = run.cameras.get(cam_name) if ev.worker.startswith("capture-") else None
        if ev.kind == "started" and ev.worker == "fuse" and run.numbered_from is not None:
            self._board.event("navigator", f"the fusion worker started again: people are numbered from "
                              f"{run.numbered_from} on (a navigator chosen by hand is looked for where "
                              "they stood; the people chosen for each or group mode must be chosen again)",
                              {"numbered_from": run.numbered_from})
        if ev.kind in ("started", "stopped"):
            log.debug("%s %s", ev.worker, ev.kind)
            return
        if cam is not None and ev.kind in ("camera_lost", "error"):
            cam.ok, cam.last_error = False, ev.message.splitlines()[0] if ev.message else ev.kind
        if cam is not None and ev.kind == "camera_ok":
            cam.ok = True
        if cam is not None and ev.kind == "ended":
            cam.ended, cam.ok, cam.last_error = True, False, "source ended"
        kind = "camera" if cam is not None or ev.worker.startswith("capture-") else "worker"
        if ev.kind == "error":
            log.warning("%s: %s", ev.worker, ev.message)
            self._board.error(run, ev.worker, ev.message)
        self._board.event(kind, f"{ev.worker}: {ev.kind} {ev.message}".strip(),
                          {"worker": ev.worker, "kind": ev.kind, "message": ev.message})

    def sample_cameras(self, run: Run) -> None:
        now = time.monotonic()
        gone = self.config.grouper.gone_after_s
        for cam in run.cameras.values():
            if cam.ring is None:  # the simulator's virtual cameras
                cam.ok = run.supervisor.group_alive("chain")
                cam.fps = run.metrics.fps.rate(now)
                continue
            seq = cam.ring.latest_seq
            if seq < 0:
                continue
            if cam.last_sample_s and now - cam.last_sample_s >= 0.5:
                cam.fps = (seq - cam.last_seq) / (now - cam.last_sample_s)
                cam.last_seq, cam.last_sample_s = seq, now
            elif not cam.last_sample_s:
                cam.last_seq, cam.last_sample_s = seq, now
            ts = cam.ring.timestamp_of(seq)
            fresh = ts is not None and now - ts <= gone
            if fresh and not cam.ok and not cam.ended:
                cam.ok = True
            elif not fresh and cam.ok:
                cam.ok = False
                cam.last_error = cam.last_error or f"no frame for {gone:.1f} s"


def _control(ctx: BaseContext, run: Run, parts: ChainParts) -> PerSpawn:
    """The fusion worker's control, new for each fusion worker (also one started again alone): a
    new queue (the one it replaces is released; the pipeline puts into ``run.control_q``) and the
    messages the worker applies before its first frame.

    Those tell a worker started again in the middle of a run (it is built from the run's start)
    where to number people from (past the ids its predecessors gave out, in this run and the
    earlier ones: an operator's choice of an id must not fall on somebody new), which navigator the
    operator had chosen and where they were, and the navigation mode and the teach adaptation the
    pipeline holds now. The queue is in place before the pipeline's chain is read: a change made
    meanwhile is either read here or put into the new queue, never into the released one."""

    def make() -> ControlChannel:
        old, run.control_q = run.control_q, ctx.Queue(maxsize=16)
        _release(old)  # its messages were for the worker that is gone
        first: list[ControlMessage] = []
        number_from = max(run.max_user_id + 1, parts.first_user_id)
        if number_from > 1:
            first.append(NumberFrom(number_from))
        if run.max_user_id:  # started again in the run, after people were numbered
            run.numbered_from = number_from
        chosen = run.operator_navigator()
        if chosen is None and run.latest is None:  # nothing fused in this run yet
            chosen = parts.resume_navigator
        if chosen is not None:
            first.append(ResumeNavigator(*chosen))
        now = parts.current()
        if now.navigation != parts.chain.navigation:
            first.append(SetNavigation(now.navigation.mode, now.navigation.user_ids))
        if now.adaptation != parts.chain.adaptation:
            first.append(SetAdaptation(now.adaptation))
        return ControlChannel(run.control_q, tuple(first))

    return PerSpawn(make)


def _release(q: mpq.Queue[T] | None) -> None:
    """Empty and close a run's queue (its feeder thread must not hold up the exit)."""
    if q is not None:
        drain(q)
        q.close()
        q.cancel_join_thread()


def _capture_group(spec: CaptureSpec, ring: RingSpec, video: VideoControl | None = None
                   ) -> Callable[[], list[WorkerDef]]:
    def build() -> list[WorkerDef]:
        return [(f"capture-{spec.camera}", capture_loop, (spec, ring, video))]

    return build
