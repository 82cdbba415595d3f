"""The live pipeline's façade: start/stop, status, navigator, workstations, events, snapshots.

Topology (one process per box; frames in shared memory, small results in mailboxes)::

    capture cam01 ─┐ shm ring
    capture cam02 ─┼──────────> detect (grouping, pose stage) ──> fuse ──> main: collector (sinks)
    ...           ─┘                                               └─> UDP/OSC stream (StreamSink)
    simulator (its detector + the pose stage's tracking) ────────> fuse ──> (same)

The chain's stages (pose stage, fusion) are built in the workers from one
:class:`~pipeline.runtime.chain.ChainConfig` (:mod:`pipeline.runtime.chain`). The façade only
coordinates; each responsibility has its module (issue 16, items 4 and 5):

- :mod:`pipeline.runtime.plan` — the run plan, checked before anything is stopped;
- :mod:`pipeline.runtime.launcher` — the launcher (worker processes, queues, rings) and the
  supervision thread (worker events, restarts, camera health, stalls);
- :mod:`pipeline.runtime.router` — the result router: the collector thread and the sinks;
- :mod:`pipeline.runtime.board` — the status: state machine, events, the status snapshot;
- :mod:`pipeline.runtime.publisher` — the status pushed to its subscribers (the web app).

Everything here is thread-safe and returns quickly. The fusion worker sends the UDP stream
itself; the main process's emitter (role ``standby``) sends the heartbeats while no fusion
worker does, from the same socket and with the same ``seq`` (:mod:`pipeline.runtime.stream`).
"""

from __future__ import annotations

import gc
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from pipeline.camera import Camera
from pipeline.emitter.udp import EmitterConfig, UdpEmitter, stream_socket
from pipeline.errors import ConfigError, InputError
from pipeline.navigation.config import NavigationConfig
from pipeline.runtime.board import StatusBoard
from pipeline.runtime.chain import ChainConfig, PoseModel, SimWorldFactory
from pipeline.runtime.config import RuntimeConfig
from pipeline.runtime.launcher import ChainParts, Launcher, Supervision
from pipeline.runtime.messages import SendPrompt, SetAdaptation, SetNavigation, SetNavigator, put_latest
from pipeline.runtime.metrics import RuntimeMetrics
from pipeline.runtime.plan import SOURCES, PlanInputs, SourceName, plan_run
from pipeline.runtime.publisher import StatusPublisher, StatusSink
from pipeline.runtime.router import ResultRouter
from pipeline.runtime.run import Run
from pipeline.runtime.shm import sweep_stale_segments
from pipeline.runtime.sinks import ResultSink, StreamSpec
from pipeline.runtime.snapshot import SnapshotCache
from pipeline.runtime.status import PipelineEvent, PipelineStatus
from pipeline.runtime.stream import StreamBook
from pipeline.runtime.tracker import guard_resource_tracker
from pipeline.takes.teach import OutputAdaptation
from pipeline.takes.video import VideoControl

__all__ = ["SOURCES", "Handover", "Pipeline", "SourceName"]


@dataclass(frozen=True, slots=True)
class Handover:
    """What a pipeline built to replace another carries on (the app rebuilds it for a new calibration
    or a newly active model): the operator's navigation mode with its chosen people, the highest
    user id given out so far, so that the new pipeline numbers people past it, the navigator the
    operator chose by hand, the stream's next ``seq`` and the operator's hold. A kept choice of
    people is then nobody until the operator ticks them again, as after a new run of the same
    pipeline: an id given out afresh never falls on somebody the operator did not choose; the
    navigator chosen by hand is looked for where they stood; the workstations see one ``seq``
    sequence (SPEC: it increases by one per datagram; a receiver may drop a datagram whose ``seq``
    went back); a hold goes on holding."""

    navigation: NavigationConfig
    numbered_past: int
    #: the navigator the operator chose by hand in the run that was stopped, and where they were last
    #: fused: looked for there in the new pipeline's first run (None: the automatic choice)
    navigator: tuple[int, tuple[float, float]] | None = None
    next_seq: int = 0
    held: bool = False  # the operator held navigation: the new pipeline sends still too



def hold_event_message(held: bool, by: str, why: str = "") -> str:
    """The ``hold`` event's message: held or released by the operator, or for ``why`` (a controller
    session's own hold: "controller session 3", "controller session 3 stopped")."""
    if by == "operator" or not why:
        return ("navigation held by the operator: the workstations get still" if held
                else "navigation released by the operator")
    return f"navigation held for {why}: the workstations get still" if held else f"navigation released: {why}"


class Pipeline:
    """The live recognition pipeline (see the module docstring).

    chain: the recognition chain's stages (:mod:`pipeline.runtime.chain`; each run puts it on its
    detector and views). pose: the detector of the image sources (cameras, videos); simulator: the
    detector of the ``simulator`` source. cameras_calibrated: the calibration of the image sources.
    """

    def __init__(self, config: RuntimeConfig, cameras_calibrated: list[Camera] | None, *,
                 camera_sources: dict[str, str] | None = None,
                 chain: ChainConfig | None = None,
                 pose: PoseModel | None = None,
                 simulator: SimWorldFactory | None = None,
                 workstations: Sequence[tuple[str, int]] = (),
                 emitter: EmitterConfig | None = None,
                 status_rate_hz: float = 10.0,
                 handover: Handover | None = None) -> None:
        guard_resource_tracker()
        sweep_stale_segments()  # what a crashed run left in /dev/shm
        self.config = config
        self.cameras_calibrated = list(cameras_calibrated) if cameras_calibrated else None
        self.camera_sources = dict(camera_sources or {})
        self.chain = chain or ChainConfig()
        self.pose = pose
        self.simulator = simulator
        self._lock = threading.RLock()  # start, stop and the control of the current run
        self._run: Run | None = None
        emitter = emitter or EmitterConfig()
        self._emitter_config = emitter
        # seq, endpoints: shared with the fusion worker's stream; a pipeline replacing another goes on
        # with its seq, a new one from the seq file's (where the last server process left off)
        try:
            self._book = StreamBook.create(handover.next_seq if handover is not None else None,
                                           seq_file=emitter.seq_file)
        except OSError as exc:
            raise ConfigError(f"the stream's seq file {emitter.seq_file} cannot be written: "
                              f"{exc.strerror or exc} (set emitter.seq_file)") from None
        self._sock = stream_socket(emitter)
        self.emitter = UdpEmitter(emitter, list(workstations), emitter.osc_endpoints or None,
                                  head=self.chain.head, shared=self._book, role="standby", sock=self._sock)
        self._board = StatusBoard(self.emitter)
        self._publisher = StatusPublisher(self.status, status_rate_hz)
        self._router = ResultRouter(self._board)
        self._launcher = Launcher(config)
        self._numbered_past = 0  # the highest user id of the runs so far: the next run numbers past it
        self._resume_navigator: tuple[int, tuple[float, float]] | None = None  # from a handover
        self._supervision = Supervision(config, self._board)
        self._snapshots = SnapshotCache(config.snapshot_interval_s, config.snapshot_long_side)
        if handover is not None:
            self._take_over(handover)
        self.emitter.start()

    # ---------------------------------------------------------------------------- lifecycle
    def start(self, source: SourceName, videos: dict[str, Path] | None = None) -> None:
        """Start (or restart) on ``source``. Bad input raises a CavewalkError and changes nothing."""
        inputs = PlanInputs(self.config, self.camera_sources,
                            tuple(self.cameras_calibrated) if self.cameras_calibrated is not None else None,
                            self.pose is not None, self.simulator is not None)
        with self._lock:
            plan = plan_run(source, videos, inputs)  # validates before anything is stopped
            resume, self._resume_navigator = self._resume_navigator, None
            if self._run is not None:  # a restart: the navigator chosen by hand goes on being it
                resume = self._stop_locked()
                gc.collect()
            self._board.starting(source)
            self._router.begin()
            self._snapshots.clear()
            parts = ChainParts(self.chain, self._stream_spec(), inputs.cameras_calibrated, self.pose,
                               self.simulator, lambda: self.chain, first_user_id=self._numbered_past + 1,
                               resume_navigator=resume)
            try:
                run = self._launcher.launch(source, plan, parts)
            except BaseException:
                self._board.failed()
                raise
            if resume is not None:
                uid, (x, y) = resume
                self._board.event("navigator", f"the navigator chosen by hand (user {uid}) is looked for "
                                  f"where they stood, ({x:.2f}, {y:.2f}) m, among the people of the new run",
                                  {"resumed": uid, "xy_m": [x, y]})
            for target, name in ((self._router.collect, "collector"),
                                 (self._supervision.watch, "supervision")):
                run.threads.append(threading.Thread(target=target, args=(run,), name=f"cavewalk-{name}",
                                                    daemon=True))
            self._run = run
            self._board.started(run)
            for t in run.threads:
                t.start()
        self._publisher.publish_now()

    def hand_over(self) -> Handover:
        """Stop, and stop sending; what a pipeline that replaces this one carries on
        (``Pipeline(..., handover=...)``, :class:`Handover`; the navigator chosen by hand only when
        the pipeline was running). Only :meth:`close` is left to call."""
        navigator = self._stop()
        self.emitter.stop()  # its last heartbeat (stopped) is sent: the next seq is the successor's
        with self._lock:
            return Handover(self.chain.navigation, self._numbered_past, navigator, self._book.peek_seq(),
                            self.emitter.held)

    def _take_over(self, handover: Handover) -> None:
        """Carry on from the pipeline this one replaces (at construction): its navigation mode and
        chosen people (this pipeline's own ``max_navigators``), people numbered past its ids, and
        its navigator chosen by hand, looked for where they stood."""
        with self._lock:
            self._numbered_past = max(self._numbered_past, handover.numbered_past)
            self._resume_navigator = handover.navigator
            navigation = replace(handover.navigation, max_navigators=self.chain.navigation.max_navigators)
            self.chain = replace(self.chain, navigation=navigation)
            chosen = list(navigation.user_ids) or "everyone"
            self._board.event("navigator", f"a new pipeline keeps navigation mode {navigation.mode} "
                              f"{chosen}; people are numbered from {self._numbered_past + 1} on",
                              {"mode": navigation.mode, "user_ids": list(navigation.user_ids),
                               "numbered_from": self._numbered_past + 1})
            if handover.held:
                self.emitter.set_held(True)  # no event: the hold goes on, it does not begin

    def _stream_spec(self) -> StreamSpec:
        return StreamSpec(self._emitter_config, self.chain.head, self._book.spec, self._sock,
                          self.config.stall_after_s)

    def stop(self) -> None:
        """Stop every worker, free the shared memory; the heartbeat goes on with state ``stopped``."""
        self._stop()

    def _stop(self) -> tuple[int, tuple[float, float]] | None:
        """:meth:`stop`; the navigator the operator had chosen by hand in the run, and where."""
        with self._lock:
            if self._run is None:
                return None
            chosen = self._stop_locked()
            self._board.stopped()
        self._publisher.publish_now()
        gc.collect()  # frees the run's named semaphores now, not at some later collection
        return chosen

    def _stop_locked(self) -> tuple[int, tuple[float, float]] | None:
        """Tear the run down; its navigator chosen by hand and where they were (None: automatic)."""
        run = self._run
        self._run = None
        if run is None:
            return None
        chosen = run.operator_navigator()
        self._launcher.teardown(run)
        self._numbered_past = max(self._numbered_past, run.max_user_id)
        self._book.release()  # no fusion worker sends now: the standby emitter does
        return chosen

    def close(self) -> None:
        """Stop the pipeline, its status publisher (after the ``stopped`` status) and the emitter
        (the heartbeat ends too)."""
        self.stop()
        self._publisher.close()
        self.emitter.close()
        self._book.release_lease()  # a clean end: the next server process goes on from here
        self._book.unlink()

    # --------------------------------------------------------------------------------- queries
    def status(self) -> PipelineStatus:
        """The status now (subscribers get it pushed: :meth:`subscribe`)."""
        return self._board.status(self.chain.navigation)

    def subscribe(self, sink: StatusSink) -> None:
        """Push the status to ``sink.on_status`` ``status_rate_hz`` times a second, and at once after
        each start and stop (:mod:`pipeline.runtime.publisher`)."""
        self._publisher.subscribe(sink)

    def unsubscribe(self, sink: StatusSink) -> None:
        self._publisher.unsubscribe(sink)

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

    def drain_events(self) -> list[PipelineEvent]:
        return self._board.drain()

    def snapshot_jpeg(self, camera: str) -> bytes | None:
        """The camera's newest frame with skeletons drawn (encoded at most every snapshot_interval_s)."""
        run = self._run
        if run is None or camera not in run.cameras:
            return None
        ring = run.cameras[camera].ring
        image = None
        if ring is not None:
            slot = ring.read_latest()
            if slot is None:
                return None
            image = slot.image
        return self._snapshots.jpeg(camera, image, run.latest, time.monotonic())

    def video_controls(self) -> dict[str, tuple[VideoControl, float]]:
        """Each capture worker's video switch and capture rate (a take's videos; {}: the simulator)."""
        with self._lock:
            run = self._run
        if run is None:
            return {}
        return {n: (c.video, c.capture_fps) for n, c in run.cameras.items() if c.video is not None}

    # ------------------------------------------------------------------------------ control
    def set_navigator(self, user_id: int | None) -> None:
        """Choose the navigator (None = automatic). InputError for a user not tracked now."""
        with self._lock:
            run = self._run
            if run is None:
                raise InputError("the pipeline is not running")
            if user_id is not None:
                if isinstance(user_id, bool) or not isinstance(user_id, int):
                    raise InputError(f"user_id must be an integer or null, got {user_id!r}")
                tracked = run.tracked(time.monotonic())
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
            config = NavigationConfig(mode, tuple(ids), self.chain.navigation.max_navigators)  # type: ignore[arg-type]
        except ValueError as exc:
            raise InputError(str(exc)) from None
        with self._lock:
            run = self._run
            if ids:
                if run is None:
                    raise InputError("the pipeline is not running: nobody is tracked to choose")
                tracked = run.tracked(time.monotonic())
                unknown = sorted(set(ids) - set(tracked))
                if unknown:
                    raise InputError(f"users {unknown} are not tracked (tracked users: "
                                     f"{', '.join(map(str, tracked)) or 'none'})")
            if config == self.chain.navigation:
                return
            self.chain = replace(self.chain, navigation=config)
            if run is not None and run.control_q is not None:
                put_latest(run.control_q, SetNavigation(config.mode, config.user_ids))
            chosen = list(config.user_ids) or "everyone"
            self._board.event("navigator", f"navigation mode {config.mode} {chosen}",
                              {"mode": config.mode, "user_ids": list(config.user_ids)})

    def set_adaptation(self, adaptation: OutputAdaptation | None) -> None:
        """A participant's teach adaptation of the recogniser's outputs (None: none), applied at once and
        kept for workers started later (pipeline.takes.teach)."""
        with self._lock:
            if adaptation == self.chain.adaptation:
                return
            self.chain = replace(self.chain, adaptation=adaptation)
            run = self._run
            if run is not None and run.control_q is not None:
                put_latest(run.control_q, SetAdaptation(adaptation))
            who = adaptation.participant_code if adaptation is not None else None
            self._board.event("adaptation", f"teach adaptation {'of ' + str(who) if adaptation else 'off'}",
                              {"state": "on" if adaptation else "off", "participant": who,
                               "adaptation_id": adaptation.adaptation_id if adaptation is not None else None})

    @property
    def held(self) -> bool:
        """Whether the operator holds navigation (:meth:`set_held`)."""
        return self.emitter.held

    def set_held(self, held: bool, by: str = "operator", why: str = "") -> bool:
        """Hold navigation (True): from the next datagram on, every locomotion command goes out
        ``still`` (speed 0, confidence 1), whatever the recogniser says, in every navigation mode,
        in this run and the next ones, until it is released (False). The recogniser goes on: the
        status shows what it says. A change is a ``hold`` event (the session's log) saying who
        changed it (``by``: "operator", or "session" for a controller session's own hold, with
        ``why``: which session, for its message); the ``hold`` datagrams say ``by`` too. Whether
        it held or released navigation (a hold taken over by the operator is said, but changes
        nothing the walls get)."""
        if not isinstance(held, bool):
            raise InputError(f"held must be true or false, got {held!r}")
        with self._lock:
            was = self.emitter.hold_by
            if was == (by if held else None):
                return False
            self.emitter.set_held(held, by)
            self._board.event("hold", hold_event_message(held, by, why), {"held": held, "by": by})
            if held == (was is not None):  # only who holds it changed (the operator took it over)
                return False
        self._publisher.publish_now()
        return True

    def set_workstations(self, endpoints: list[tuple[str, int]]) -> None:
        """Replace the UDP destinations; InputError (nothing changes) for one that does not resolve."""
        self.emitter.set_endpoints(list(endpoints))
        self._board.event("state", f"workstations: {endpoints}",
                          {"workstations": [list(e) for e in endpoints]})

    def send_prompt(self, text: str, label: str, remaining_s: float) -> None:
        """One ``prompt`` datagram on the stream (by the fusion worker while it sends the stream)."""
        run = self._run
        if run is not None and run.control_q is not None and self._book.fusion_sends():
            put_latest(run.control_q, SendPrompt(text, label, remaining_s))
        else:
            self.emitter.send_prompt(text, label, remaining_s)

    def add_sink(self, sink: ResultSink) -> None:
        """Hand every fused ``FrameResult`` to ``sink.on_result`` (collector thread: it must not block)."""
        self._router.add(sink)

    def remove_sink(self, sink: ResultSink) -> None:
        self._router.remove(sink)
