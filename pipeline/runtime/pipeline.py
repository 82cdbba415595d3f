"""The live pipeline's façade: start/stop, status, navigator, workstations, events, snapshots.

Topology (one process per box; frames in shared memory, small results in bounded queues)::

    capture cam01 ─┐ shm ring
    capture cam02 ─┼──────────> detect (grouping + batched pose) ──q──> fuse ──q──> main: collector
    ...           ─┘                                                     └─> UDP/OSC stream (StreamSink)
    simulator ───────────────────────────────────────────────────q──> fuse ──q──> (same)

Everything here is thread-safe and returns quickly; the work happens in the worker
processes and in two threads of the main process (collector, supervision). The fusion
worker sends the UDP stream itself; the main process's emitter (role ``standby``) sends the
heartbeats while no fusion worker does, from the same socket and with the same ``seq``
(:mod:`pipeline.runtime.stream`).
"""

from __future__ import annotations

import gc
import logging
import math
import multiprocessing as mp
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Literal, Protocol

from pipeline.camera import Camera
from pipeline.emitter.udp import EmitterConfig, UdpEmitter, stream_socket
from pipeline.errors import InputError, SourceError
from pipeline.navigation.config import NavigationConfig
from pipeline.navigation.views import navigation_record
from pipeline.results import FrameResult, action_record, person_record
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.mailbox import Mailbox
from pipeline.runtime.messages import (
    FusedFrame,
    SendPrompt,
    SetAdaptation,
    SetNavigation,
    SetNavigator,
    WorkerEvent,
    put_latest,
)
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.shm import FrameRing, RingSpec
from pipeline.runtime.sinks import ResultSink, StreamSpec
from pipeline.runtime.snapshot import person_labels, render_snapshot
from pipeline.runtime.stages import FusionFactory
from pipeline.runtime.status import PipelineEvent, PipelineStatus, State
from pipeline.runtime.stream import StreamBook
from pipeline.runtime.supervisor import Supervisor, WorkerDef, drain
from pipeline.runtime.tracker import guard_resource_tracker
from pipeline.runtime.workers import CaptureSpec, DetectSpec, capture_loop, detect_loop, fuse_loop, sim_loop
from pipeline.sources import source_kind
from pipeline.sources.opencv import probe_video
from pipeline.takes.video import VideoControl

log = logging.getLogger(__name__)

SourceName = Literal["simulator", "cameras", "videos"]
SOURCES: tuple[str, ...] = ("simulator", "cameras", "videos")
EVENT_LOG_SIZE = 2000
# imported once by the fork server, so a worker (re)started from it runs at once
FORKSERVER_PRELOAD = ["numpy", "cv2", "pipeline.runtime.workers", "pipeline.runtime.stages",
                      "pipeline.triangulation.reconstructor", "pipeline.triangulation.navigator"]


class SimFactory(Protocol):
    """Builds the simulator inside its worker; tells the main process its virtual cameras."""

    @property
    def cameras(self) -> tuple[Camera, ...]: ...

    @property
    def fps(self) -> float: ...

    def __call__(self) -> Any: ...


@dataclass
class _Camera:
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
class _Run:
    source: str
    cameras: dict[str, _Camera]
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


class Pipeline:
    """The live recognition pipeline (see the module docstring)."""

    def __init__(self, config: RuntimeConfig, cameras_calibrated: list[Camera] | None, *,
                 camera_sources: dict[str, str] | None = None,
                 pose_factory: Callable[[], Any] | None = None,
                 fusion: FusionFactory | None = None,
                 sim_factory: SimFactory | None = None,
                 workstations: Sequence[tuple[str, int]] = (),
                 emitter: EmitterConfig | None = None) -> None:
        guard_resource_tracker()
        self.config = config
        self.cameras_calibrated = list(cameras_calibrated) if cameras_calibrated else None
        self.camera_sources = dict(camera_sources or {})
        self.pose_factory = pose_factory
        self.fusion = fusion or FusionFactory(cameras=None, camera_names=())
        self.sim_factory = sim_factory
        self._lock = threading.RLock()
        self._state: State = "stopped"
        self._last_error: str | None = None
        self._run: _Run | None = None
        self._events: deque[PipelineEvent] = deque(maxlen=EVENT_LOG_SIZE)
        self._last_action: str | None = None
        self._snapshots: dict[str, tuple[float, bytes]] = {}
        self._sinks: tuple[ResultSink, ...] = ()  # main-process sinks (the take recorder)
        emitter = emitter or EmitterConfig()
        self._emitter_config = emitter
        self._book = StreamBook.create()  # seq, endpoints: shared with the fusion worker's stream
        self._sock = stream_socket(emitter)
        self.emitter = UdpEmitter(emitter, list(workstations), emitter.osc_endpoints or None,
                                  head=self.fusion.head, shared=self._book, role="standby", sock=self._sock)
        self.emitter.set_state("stopped")
        self.emitter.start()

    # ---------------------------------------------------------------------------- lifecycle
    def start(self, source: SourceName, videos: dict[str, Path] | None = None) -> None:
        """Start (or restart) on ``source``. Bad input raises a CavewalkError and changes nothing."""
        if source not in SOURCES:
            raise InputError(f"source must be one of {', '.join(SOURCES)}, got {source!r}")
        with self._lock:
            plan = self._plan(source, videos)  # validates before anything is stopped
            if self._run is not None:
                self._stop_locked()
                gc.collect()
            self._launch(source, plan)

    def _plan(self, source: str, videos: dict[str, Path] | None) -> dict[str, str]:
        """camera name -> source URI for the capture workers ({} for the simulator)."""
        if source == "simulator":
            if self.sim_factory is None:
                raise SourceError("the simulator is not available in this pipeline")
            return {}
        if source == "cameras":
            plan = {n: u for n, u in self.camera_sources.items() if source_kind(u) != "sim"}
            if not plan:
                raise SourceError("no camera has a real source in the settings (all are 'sim'); "
                                  "set cameras[].source to a device index, URL, video or folder")
            for name, uri in plan.items():
                if source_kind(uri) in ("video", "folder") and not Path(uri).expanduser().exists():
                    raise SourceError(f"camera {name}: source {uri!r} not found")
        else:
            if not videos:
                raise InputError("the videos source needs at least one video (camera name -> file)")
            plan = {}
            for name, path in videos.items():
                if not Path(path).is_file():
                    raise InputError(f"camera {name}: video not found: {path}")
                plan[name] = str(path)
        if self.cameras_calibrated is not None:
            known = {c.name for c in self.cameras_calibrated}
            unknown = sorted(set(plan) - known)
            if unknown:
                raise InputError(f"cameras {unknown} are not in the calibration (it has {sorted(known)})")
        if self.pose_factory is None:
            raise SourceError("no pose detector configured for image sources")
        for name, uri in plan.items():
            if source_kind(uri) == "video":
                (w, h), _ = probe_video(name, Path(uri))
                if _slot_bytes(w, h) > self.config.max_frame_bytes:
                    raise SourceError(f"camera {name}: {w}x{h} frames exceed the ring slots "
                                      f"({self.config.max_frame_bytes} bytes)")
        return plan

    def _launch(self, source: str, plan: dict[str, str]) -> None:
        ctx = mp.get_context(self.config.start_method)
        if self.config.start_method == "forkserver":
            ctx.set_forkserver_preload(FORKSERVER_PRELOAD)
        events_q = ctx.Queue(maxsize=1000)
        run = _Run(source=source, cameras={}, events_q=events_q, supervisor=Supervisor(ctx, events_q),
                   metrics=RuntimeMetrics(self.config.latency_window))
        self._state = "starting"
        self._last_error = None
        self._last_action = None
        self._snapshots.clear()
        self.emitter.set_state("starting")
        self._event("state", f"starting ({source})", {"state": "starting", "source": source})
        try:
            if source == "simulator":
                sim = self.sim_factory
                if sim is None:
                    raise SourceError("the simulator is not available in this pipeline")
                run.cameras = {c.name: _Camera(c.name, ok=True) for c in sim.cameras}
                fusion = replace(self.fusion, cameras=tuple(sim.cameras),
                                 camera_names=tuple(c.name for c in sim.cameras))

                run.det_box, run.out_box = Mailbox.create("det"), Mailbox.create("fused")
                det, out = run.det_box.spec, run.out_box.spec

                stream = self._stream_spec()

                def build_sim() -> list[WorkerDef]:
                    run.control_q = ctx.Queue(maxsize=16)
                    return [("simulator", sim_loop, (sim, sim.fps, det)),
                            ("fuse", fuse_loop, (fusion, det, out, run.control_q, stream))]

                run.supervisor.add_group("chain", build_sim)
            else:
                self._launch_images(ctx, run, plan)
        except BaseException:
            self._teardown(run)
            self._state = "error"
            raise
        for target, name in ((self._collect, "collector"), (self._supervise, "supervision")):
            t = threading.Thread(target=target, args=(run,), name=f"cavewalk-{name}", daemon=True)
            run.threads.append(t)
        self._run = run
        for t in run.threads:
            t.start()

    def _launch_images(self, ctx: Any, run: _Run, plan: dict[str, str]) -> None:
        names = tuple(plan)
        start_s = time.monotonic() + 0.5  # one trigger for every file source: they stay in step
        pace = self.config.video_pace_fps
        for name, uri in plan.items():
            kind = source_kind(uri)
            capacity, native_fps = self.config.max_frame_bytes, 30.0
            if kind == "video":
                (w, h), fps = probe_video(name, Path(uri))
                capacity, native_fps = _slot_bytes(w, h), fps or 30.0
            ring = FrameRing.create(self.config.ring_slots, capacity, name)
            file_like = kind in ("video", "folder")
            pace_fps = (None if pace == 0 else pace or native_fps) if file_like else None
            run.cameras[name] = cam = _Camera(name, ring, video=VideoControl.create(ctx),
                                              capture_fps=pace_fps or native_fps)
            spec = CaptureSpec(name, uri, pace_fps=pace_fps,
                               loop=self.config.video_loop if file_like else False,
                               start_s=start_s, retry_s=self.config.camera_retry_s,
                               nice=self.config.capture_nice)
            run.supervisor.add_group(f"capture-{name}", _capture_group(spec, ring.spec, cam.video))
        calibrated = None
        if self.cameras_calibrated is not None:
            calibrated = tuple(c for c in self.cameras_calibrated if c.name in plan)
            if len(calibrated) < 2:
                calibrated = None
        fusion = replace(self.fusion, cameras=calibrated, camera_names=names)
        dspec = DetectSpec(names, self.config.target_fps, self.config.grouper)
        rings = tuple(run.cameras[n].ring.spec for n in names)  # type: ignore[union-attr]
        pose = self.pose_factory
        with_cameras = getattr(pose, "with_cameras", None)
        if with_cameras is not None:  # the pose stage tracks each camera's people as well
            pose = with_cameras(names)

        run.det_box, run.out_box = Mailbox.create("det"), Mailbox.create("fused")
        det, out = run.det_box.spec, run.out_box.spec
        stream = self._stream_spec()

        def build_chain() -> list[WorkerDef]:
            run.control_q = ctx.Queue(maxsize=16)
            return [("detect", detect_loop, (dspec, rings, pose, det)),
                    ("fuse", fuse_loop, (fusion, det, out, run.control_q, stream))]

        run.supervisor.add_group("chain", build_chain)

    def _stream_spec(self) -> StreamSpec:
        return StreamSpec(self._emitter_config, self.fusion.head, self._book.spec, self._sock,
                          self.config.stall_after_s)

    def stop(self) -> None:
        """Stop every worker, free the shared memory; the heartbeat goes on with state ``stopped``."""
        with self._lock:
            if self._run is None:
                return
            self._stop_locked()
            self._state = "stopped"
            self.emitter.set_state("stopped")
            self._event("state", "stopped", {"state": "stopped"})
        gc.collect()  # frees the run's named semaphores now, not at some later collection

    def _stop_locked(self) -> None:
        run = self._run
        self._run = None
        if run is None:
            return
        self._teardown(run)
        self._book.release()  # no fusion worker sends now: the standby emitter does

    def _teardown(self, run: _Run) -> None:
        run.stop.set()
        run.supervisor.stop()
        for t in run.threads:
            if t is not threading.current_thread():
                t.join(timeout=2.0)
        for q in (run.control_q, run.events_q):
            if q is not None:
                drain(q)
                q.close()
                q.cancel_join_thread()
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

    def close(self) -> None:
        """Stop the pipeline and the emitter (the heartbeat ends too)."""
        self.stop()
        self.emitter.close()
        self._book.unlink()

    # ---------------------------------------------------------------------- main-process threads
    def _collect(self, run: _Run) -> None:
        box = run.out_box
        while not run.stop.is_set() and box is not None:
            try:
                got = box.get_all(timeout=0.1)  # every result in order: each may carry events
            except (OSError, ValueError, TypeError):  # the run is being torn down
                return
            except Exception:  # a message that does not unpickle
                log.exception("bad message from the fusion worker")
                continue
            for fused in got:
                if isinstance(fused, FusedFrame):
                    try:
                        self._on_result(run, fused)
                    except Exception:
                        log.exception("handling a result failed")

    def _on_result(self, run: _Run, fused: FusedFrame) -> None:
        result, det = fused.result, fused.detected
        nav = result.navigation
        sent = fused.sent_s if fused.sent_s is not None else fused.fuse_end_s  # the fusion worker sent it
        ms = {
            "capture": det.detect_start_s - det.timestamp_s,
            "detect": det.detect_end_s - det.detect_start_s,
            "fuse": fused.fuse_end_s - det.detect_end_s,
            "emit": sent - fused.fuse_end_s,
            "end_to_end": sent - det.timestamp_s,
        }
        now = time.monotonic()
        if run.first_source_index is None:
            run.first_source_index = det.source_index
        elif det.source_index + 5 < run.last_source_index:  # the source restarted from frame 0
            run.produced_before += run.last_source_index - run.first_source_index + 1
            run.first_source_index = det.source_index
            run.last_source_index = det.source_index
        run.last_source_index = max(run.last_source_index, det.source_index)
        run.metrics.frame(now, {k: v * 1000.0 for k, v in ms.items()}, 0)
        run.latest = fused
        run.last_result_s = now
        run.supervisor.note_progress()
        for sink in self._sinks:  # each returns at once (queues its own work)
            try:
                sink.on_result(result)
            except Exception:
                log.exception("result sink %r failed", sink)
        with self._lock:
            if self._run is run and self._state in ("starting", "error", "stalled"):
                self._state = "running"
                self.emitter.set_state("running")
                self._event("state", "running", {"state": "running", "source": run.source})
            for change in fused.navigator_changes:
                self._event("navigator", f"navigator {change.previous} -> {change.current} ({change.reason})",
                            {"previous": change.previous, "current": change.current, "mode": change.mode})
            mode = nav.mode if nav is not None else "single"
            for c in nav.changes if nav is not None and mode != "single" else ():  # each person's own
                who = "group" if c.user_id is None else f"user {c.user_id}"
                own = nav.command_of(c.user_id) if nav is not None and c.user_id is not None else None
                self._event("action", f"{who}: action {c.previous} -> {c.current} ({mode})",
                            {"previous": c.previous, "label": c.current, "user_id": c.user_id, "mode": mode,
                             "group": c.user_id is None,
                             "action": action_record(own.action if own is not None else None)})
            label = result.action.label if result.action is not None else None
            if label != self._last_action and mode == "single":
                self._event("action", f"action {self._last_action} -> {label}",
                            {"previous": self._last_action, "label": label, "user_id": result.navigator,
                             "action": action_record(result.action)})
            self._last_action = label

    def _supervise(self, run: _Run) -> None:
        while not run.stop.is_set():
            for ev in drain(run.events_q):
                if isinstance(ev, WorkerEvent):
                    run.supervisor.note_event(ev)
                    self._on_worker_event(run, ev)
            for ev in run.supervisor.check():
                self._on_worker_event(run, ev)
            self._sample_cameras(run)
            self._check_stall(run)
            run.stop.wait(0.05)

    def _check_stall(self, run: _Run) -> None:
        """``running`` -> ``stalled`` when no frame was fused for ``stall_after_s`` (heartbeats say so)."""
        gone = time.monotonic() - run.last_result_s
        with self._lock:
            if self._run is run and self._state == "running" and gone > self.config.stall_after_s:
                self._state = "stalled"
                self.emitter.set_state("stalled")
                self._event("state", f"stalled (no frame for {gone:.1f} s)",
                            {"state": "stalled", "source": run.source})

    def _on_worker_event(self, run: _Run, ev: WorkerEvent) -> None:
        cam_name = ev.worker.removeprefix("capture-")
        cam = run.cameras.get(cam_name) if ev.worker.startswith("capture-") else None
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
            with self._lock:
                self._last_error = f"{ev.worker}: {ev.message.splitlines()[0] if ev.message else 'error'}"
                if ev.worker == "chain" and self._run is run:  # no results until it is back
                    self._state = "error"
                    self.emitter.set_state("error")
        with self._lock:
            self._event(kind, f"{ev.worker}: {ev.kind} {ev.message}".strip(),
                        {"worker": ev.worker, "kind": ev.kind, "message": ev.message})

    def _sample_cameras(self, run: _Run) -> None:
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

    # --------------------------------------------------------------------------------- queries
    def status(self) -> PipelineStatus:
        with self._lock:
            run, state, error = self._run, self._state, self._last_error
        if run is None:
            return PipelineStatus(state, None, 0.0, 0, 0, RuntimeMetrics().latency_summary(), (), (),
                                  None, "auto", None, (), -1, error, tuple(self.emitter.endpoints),
                                  self.emitter.sent, navigation_record(None, self.fusion.navigation))
        now = time.monotonic()
        latest = run.latest
        result = latest.result if latest is not None else FrameResult(-1, 0.0)
        processed = run.metrics.processed
        produced = run.produced_before + (run.last_source_index - run.first_source_index + 1
                                          if run.first_source_index is not None else 0)
        people = tuple({"user_id": p.user_id, "position_m": [_f(v) for v in p.position_m],
                        "reproj_px": _f(p.reproj_px)} for p in result.people3d)
        return PipelineStatus(
            state=state, source=run.source, fps=round(run.metrics.fps.rate(now), 2),
            dropped=max(0, produced - processed), processed=processed,
            latency_ms=run.metrics.latency_summary(),
            cameras=tuple({"name": c.name, "ok": c.ok, "fps": round(c.fps, 2), "last_error": c.last_error}
                          for c in run.cameras.values()),
            people=people, navigator=result.navigator,
            navigator_mode=latest.navigator_mode if latest is not None else "auto",
            action=action_record(result.action), people3d=tuple(person_record(p) for p in result.people3d),
            frame_index=result.frame_index, last_error=error,
            workstations=tuple(self.emitter.endpoints), emitted=self.emitter.sent,
            navigation=navigation_record(result.navigation, self.fusion.navigation),
        )

    def latency_samples(self) -> dict[str, list[float]]:
        """The raw latency window of every stage (ms), for benchmarks."""
        run = self._run
        return {} if run is None else {k: w.values() for k, w in run.metrics.latency.items()}

    def reset_metrics(self) -> None:
        """Start the latency windows and the frame counters afresh (benchmarks skip the warm-up)."""
        run = self._run
        if run is not None:
            run.metrics = RuntimeMetrics(self.config.latency_window)
            run.first_source_index = None
            run.last_source_index = -1
            run.produced_before = 0

    def worker_pids(self) -> list[int]:
        run = self._run
        return [] if run is None else run.supervisor.pids()

    def workers(self) -> dict[str, int]:
        """Worker name (``capture-cam01``, ``detect``, ``fuse``, ``simulator``) -> pid."""
        run = self._run
        return {} if run is None else run.supervisor.workers()

    def set_navigator(self, user_id: int | None) -> None:
        """Choose the navigator (None = automatic). InputError for a user not tracked now."""
        with self._lock:
            run = self._run
            if run is None:
                raise InputError("the pipeline is not running")
            if user_id is not None:
                if isinstance(user_id, bool) or not isinstance(user_id, int):
                    raise InputError(f"user_id must be an integer or null, got {user_id!r}")
                people = run.latest.result.people3d if run.latest is not None else ()
                tracked = sorted(p.user_id for p in people)
                if user_id not in tracked:
                    raise InputError(f"user {user_id} is not tracked (tracked users: "
                                     f"{', '.join(map(str, tracked)) or 'none'})")
            if run.control_q is not None:
                put_latest(run.control_q, SetNavigator(user_id))

    def set_navigation(self, mode: str, user_ids: Sequence[int] = ()) -> None:
        """The navigation mode (issue 20): ``single``, ``each`` or ``group``, with the chosen people
        (empty = everyone tracked). InputError, nothing changed, for an unknown mode or a user id
        nobody has now; the mode also holds for the next runs."""
        ids = list(user_ids)
        try:
            config = NavigationConfig(mode, tuple(ids), self.fusion.navigation.max_navigators)  # type: ignore[arg-type]
        except ValueError as exc:
            raise InputError(str(exc)) from None
        with self._lock:
            run = self._run
            if ids:
                if run is None:
                    raise InputError("the pipeline is not running: nobody is tracked to choose")
                people = run.latest.result.people3d if run.latest is not None else ()
                tracked = sorted(p.user_id for p in people)
                unknown = sorted(set(ids) - set(tracked))
                if unknown:
                    raise InputError(f"users {unknown} are not tracked (tracked users: "
                                     f"{', '.join(map(str, tracked)) or 'none'})")
            if config == self.fusion.navigation:
                return
            self.fusion = replace(self.fusion, navigation=config)
            if run is not None and run.control_q is not None:
                put_latest(run.control_q, SetNavigation(config.mode, config.user_ids))
            self._event("navigator", f"navigation mode {config.mode} {list(config.user_ids) or 'everyone'}",
                        {"mode": config.mode, "user_ids": list(config.user_ids)})

    def set_adaptation(self, adaptation: Any) -> None:
        """A participant's teach adaptation of the recogniser's outputs (None: none), applied at once and
        kept for workers started later (pipeline.takes.teach.OutputAdaptation)."""
        with self._lock:
            if adaptation == self.fusion.adaptation:
                return
            self.fusion = replace(self.fusion, adaptation=adaptation)
            run = self._run
            if run is not None and run.control_q is not None:
                put_latest(run.control_q, SetAdaptation(adaptation))
            who = getattr(adaptation, "participant_code", None)
            self._event("adaptation", f"teach adaptation {'of ' + str(who) if adaptation else 'off'}",
                        {"state": "on" if adaptation else "off", "participant": who,
                         "adaptation_id": getattr(adaptation, "adaptation_id", None)})

    def set_workstations(self, endpoints: list[tuple[str, int]]) -> None:
        """Replace the UDP destinations; InputError (nothing changes) for one that does not resolve."""
        self.emitter.set_endpoints(list(endpoints))
        with self._lock:
            self._event("state", f"workstations: {endpoints}", {"workstations": [list(e) for e in endpoints]})

    def video_controls(self) -> dict[str, tuple[VideoControl, float]]:
        """Each capture worker's video switch and capture rate (a take's videos; {}: the simulator)."""
        with self._lock:
            run = self._run
        if run is None:
            return {}
        return {n: (c.video, c.capture_fps) for n, c in run.cameras.items() if c.video is not None}

    def send_prompt(self, text: str, label: str, remaining_s: float) -> None:
        """One ``prompt`` datagram on the stream (by the fusion worker while it sends the stream)."""
        run = self._run
        if run is not None and run.control_q is not None and self._book.fusion_sends():
            put_latest(run.control_q, SendPrompt(text, label, remaining_s))
        else:
            self.emitter.send_prompt(text, label, remaining_s)

    def add_sink(self, sink: ResultSink) -> None:
        """Hand every fused ``FrameResult`` to ``sink.on_result`` (collector thread: it must not block)."""
        with self._lock:
            if sink not in self._sinks:
                self._sinks = (*self._sinks, sink)

    def remove_sink(self, sink: ResultSink) -> None:
        with self._lock:
            self._sinks = tuple(s for s in self._sinks if s is not sink)

    def drain_events(self) -> list[PipelineEvent]:
        with self._lock:
            out = list(self._events)
            self._events.clear()
            return out

    def _event(self, kind: str, message: str, data: dict[str, Any]) -> None:
        self._events.append(PipelineEvent(time.time(), kind, message, data))

    def snapshot_jpeg(self, camera: str) -> bytes | None:
        """The camera's newest frame with skeletons drawn (encoded at most every snapshot_interval_s)."""
        run = self._run
        if run is None or camera not in run.cameras:
            return None
        now = time.monotonic()
        cached = self._snapshots.get(camera)
        if cached is not None and now - cached[0] < self.config.snapshot_interval_s:
            return cached[1]
        cam = run.cameras[camera]
        latest = run.latest
        views = latest.detected.views if latest is not None else ()
        view = next((v for v in views if v.camera == camera), None)
        image = None
        if cam.ring is not None:
            slot = cam.ring.read_latest()
            if slot is None:
                return None
            image = slot.image
        elif view is None:
            return None
        labels = None
        if view is not None and latest is not None:  # track ids, user ids, the navigator's colour
            result = latest.result
            tracked = next((t for t in result.views if t.camera == camera), None)
            labels = person_labels(view, tracked, result.people3d, result.navigator)
        data = render_snapshot(image, view, self.config.snapshot_long_side, labels=labels)
        self._snapshots[camera] = (now, data)
        return data


# ------------------------------------------------------------------------------------ helpers
def _capture_group(spec: CaptureSpec, ring: RingSpec, video: VideoControl | None = None
                   ) -> Callable[[], list[WorkerDef]]:
    def build() -> list[WorkerDef]:
        return [(f"capture-{spec.camera}", capture_loop, (spec, ring, video))]

    return build


def _f(x: float) -> float | None:
    return round(float(x), 4) if math.isfinite(float(x)) else None


def _slot_bytes(width: int, height: int) -> int:
    """A video's ring slot: its frame size, with room for decoders that pad to 16 pixels."""
    return (width + 16) * (height + 16) * 3
