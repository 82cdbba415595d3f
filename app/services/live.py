"""The app's owner of the recognition pipeline.

:class:`PipelineService` holds the runtime's ``Pipeline`` façade (``pipeline.runtime``) and
subscribes to its status, which the pipeline pushes (``pipeline.runtime.publisher``:
``server.live_rate_hz`` times a second, and at once after a start or stop).
Each :class:`~pipeline.runtime.status.PipelineStatus` is kept as it came, with its one JSON form
(``PipelineStatus.to_json``: ``GET /status``), and handed on without re-shaping: to the status
sinks (the 3D view, the no-locomotion watch), to the WebSockets (:class:`LiveFeed`), and the
pipeline's events since the last status to the event log (:class:`~app.services.event_log.EventWriter`,
so a running study session gets every action, navigator and state change). Requests never wait
for the pipeline: they read the newest status.
"""

from __future__ import annotations

import asyncio
import contextlib
import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import replace
from enum import Enum
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np

from app.db.errors import StateConflict
from app.services.event_log import EventWriter
from pipeline.errors import InputError
from pipeline.navigation.config import NavigationConfig
from pipeline.runtime.pipeline import Handover, hold_event_message
from pipeline.runtime.plan import SourceName
from pipeline.runtime.publisher import StatusSink
from pipeline.runtime.sinks import ResultSink
from pipeline.runtime.status import NavigationStatus, PipelineEvent, PipelineStatus
from pipeline.takes.files import write_atomic
from pipeline.takes.teach import OutputAdaptation
from pipeline.takes.video import VideoControl

log = logging.getLogger(__name__)

#: beside the database: "held" while navigation is held (a server started again holds too), and
#: "session N" on its second line while the hold is controller session N's own
HOLD_FILE = "navigation-hold"

__all__ = ["HOLD_FILE", "LiveFeed", "LiveSink", "PipelineFactory", "PipelineService", "PipelineUnavailable",
           "SourceName", "UnknownUser"]


class PipelineUnavailable(RuntimeError):
    """The pipeline cannot be built (its runtime or a part of it is missing)."""


class UnknownUser(LookupError):
    """No tracked person has this user id."""


class PipelineFacade(Protocol):
    """What the app uses of ``pipeline.runtime.pipeline.Pipeline``."""

    def start(self, source: SourceName, videos: dict[str, Path] | None = None) -> None: ...
    def stop(self) -> None: ...
    def close(self) -> None: ...
    def subscribe(self, sink: StatusSink) -> None: ...
    def drain_events(self) -> list[PipelineEvent]: ...
    def set_navigator(self, user_id: int | None) -> None: ...
    def set_navigation(self, mode: str, user_ids: list[int]) -> None: ...
    def set_adaptation(self, adaptation: OutputAdaptation | None) -> None: ...
    def set_held(self, held: bool, by: str = "operator", why: str = "") -> bool: ...
    @property
    def held(self) -> bool: ...
    def add_sink(self, sink: ResultSink) -> None: ...
    def snapshot_jpeg(self, camera: str) -> bytes | None: ...
    def send_prompt(self, text: str, label: str, remaining_s: float) -> None: ...
    def video_controls(self) -> dict[str, tuple[VideoControl, float]]: ...
    def hand_over(self) -> Handover: ...


#: Builds a pipeline; given a :class:`Handover`, one that carries on from the pipeline it replaces.
PipelineFactory = Callable[[Handover | None], PipelineFacade]


class LiveSink(Protocol):
    """Something that shows each status (the viser 3D view, the no-locomotion watch): the typed
    status and its JSON form (``message``), on the pipeline's status thread; returns quickly."""

    def on_status(self, status: PipelineStatus, message: Mapping[str, Any]) -> None: ...


class LiveFeed:
    """The live status to every WebSocket, from the app's event loop.

    :meth:`publish` (any thread) says that the pipeline pushed a new status or one of the app's
    own live facts changed; the feed then composes the message once (``compose``: the newest
    status and the app's facts) and hands it to every socket's queue, never more often than
    ``rate_hz``. Each socket awaits its queue (:meth:`subscribe`), which keeps only the newest
    message: a slow client skips messages, it never builds a backlog, and no socket polls. While
    no pipeline publishes (none built yet, or none can be), the feed keeps the sockets' rate on
    its own clock (:meth:`own_clock`): one clock at a time, the pipeline's or the feed's.
    """

    def __init__(self, compose: Callable[[], dict[str, Any]], rate_hz: float) -> None:
        if not rate_hz > 0:
            raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
        self.compose = compose
        self.period_s = 1.0 / rate_hz
        self._loop: asyncio.AbstractEventLoop | None = None
        self._queues: set[asyncio.Queue[dict[str, Any]]] = set()
        self._last_s = -math.inf
        self._due: asyncio.TimerHandle | None = None
        self._pending = False  # something was published since the last message
        self._ticking = True  # the feed's own clock (no pipeline publishes)

    def bind(self, loop: asyncio.AbstractEventLoop) -> None:
        """The event loop the sockets run on (the app's lifespan's)."""
        self._loop = loop

    def subscribe(self) -> asyncio.Queue[dict[str, Any]]:
        """A new socket's queue (in the event loop): it gets each message from now on."""
        q: asyncio.Queue[dict[str, Any]] = asyncio.Queue(maxsize=1)
        self._queues.add(q)
        self._schedule()
        return q

    def unsubscribe(self, q: asyncio.Queue[dict[str, Any]]) -> None:
        self._queues.discard(q)

    def publish(self) -> None:
        """A new status or a changed fact (any thread): the sockets get it within the period."""
        self._call(self._published)

    def own_clock(self, on: bool) -> None:
        """Whether the feed keeps the sockets' rate itself (no pipeline publishes) (any thread)."""
        self._call(lambda: self._set_ticking(on))

    def _call(self, fn: Callable[[], None]) -> None:
        loop = self._loop
        if loop is None or loop.is_closed():
            return
        with contextlib.suppress(RuntimeError):  # the loop closed meanwhile (shutdown)
            loop.call_soon_threadsafe(fn)

    def _published(self) -> None:
        self._pending = True
        self._schedule()

    def _set_ticking(self, on: bool) -> None:
        self._ticking = on
        self._schedule()

    def _schedule(self) -> None:
        """The next message, as soon as the rate allows, if one is wanted and none is due yet."""
        if self._due is not None or not self._queues or not (self._pending or self._ticking):
            return
        if self._loop is not None:
            wait_s = max(0.0, self._last_s + self.period_s - time.monotonic())
            self._due = self._loop.call_later(wait_s, self._send)

    def _send(self) -> None:
        self._due = None
        if not self._queues:
            return
        self._pending = False
        self._last_s = time.monotonic()
        try:
            message = self.compose()
        except Exception:  # the loop boundary: report, keep serving
            log.exception("composing the live status failed")
        else:
            for q in self._queues:
                if q.full():
                    q.get_nowait()  # the client has not taken the last one: the newest replaces it
                q.put_nowait(message)
        self._schedule()  # on the feed's own clock: the next one period later


def jsonable(obj: Any) -> Any:
    """Dataclasses, numpy arrays and scalars, enums, tuples -> plain JSON values (NaN -> None)."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, Enum):
        return jsonable(obj.value)
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Path):
        return str(obj)
    return obj


#: The runtime's event kinds -> the event log's kinds (others are kept as they are).
EVENT_KINDS = {"state": "pipeline", "worker": "pipeline", "camera": "pipeline"}


def event_fields(event: PipelineEvent) -> tuple[str, dict[str, Any], float]:
    """A runtime ``PipelineEvent`` -> (the event log's kind, its payload, unix ts)."""
    payload: dict[str, Any] = {str(k): jsonable(v) for k, v in event.data.items()}
    payload["message"] = event.message
    if event.kind in ("worker", "camera"):
        payload.setdefault("source", event.kind)
    ts = event.timestamp_s if math.isfinite(event.timestamp_s) else time.time()
    return EVENT_KINDS.get(event.kind, event.kind), payload, ts


class _Subscription:
    """One pipeline's status subscriber: the service learns which pipeline a status is from."""

    def __init__(self, service: PipelineService, pipeline: PipelineFacade) -> None:
        self._service = service
        self._pipeline = pipeline

    def on_status(self, status: PipelineStatus) -> None:
        self._service.on_status(self._pipeline, status)


def _read_hold(path: Path) -> tuple[bool, int | None]:
    """Whether ``path`` says navigation is held, and the controller session whose own hold it is (None:
    the operator's). A file that cannot be read: held (the operator's), and said."""
    try:
        words = path.read_bytes().split()
    except FileNotFoundError:
        return False, None
    except OSError as exc:
        log.error("%s cannot be read (%s): navigation is held until the operator releases it", path, exc)
        return True, None
    if words[:1] != [b"held"]:
        return False, None
    if len(words) == 3 and words[1] == b"session" and words[2].isdigit():
        return True, int(words[2])
    return True, None


class PipelineService:
    """Owns one pipeline (built on first start by ``factory``) and hands its pushed status on."""

    def __init__(
        self,
        factory: PipelineFactory | None,
        events: EventWriter,
        sinks: tuple[LiveSink, ...] = (),
        feed: LiveFeed | None = None,
        hold_file: Path | None = None,
    ) -> None:
        self._factory = factory
        self._events = events
        self._sinks = sinks
        self.feed = feed
        self._pipeline: PipelineFacade | None = None
        # _lock serialises the control of the pipeline (start, stop, navigator, rebuild), which may
        # take seconds (spawning or joining workers, on a busy machine many); _snap_lock guards only
        # the newest status, so that status reads (GET /status, every WebSocket message, on the
        # event loop) never wait for a start or stop (issue 15 S3: they did, and timed out)
        self._lock = threading.RLock()
        self._snap_lock = threading.Lock()
        self._status = PipelineStatus("stopped" if factory else "unavailable")
        self._snapshot: dict[str, Any] = self._status.to_json()
        self.unavailable_reason = "" if factory else "the pipeline runtime is not available"
        # what the next start rebuilds the pipeline for ("calibration", "model"), while the running
        # one goes on without it; the last start's source and videos (a restart repeats them)
        self._rebuild_for: set[str] = set()
        # the active calibration run (the app's; None: none) and the one the pipeline was built with
        self._active_calibration: Callable[[], int | None] = lambda: None
        self._built_calibration: int | None = None
        # whether a model was activated elsewhere (the command line) since the pipeline was built, and
        # when that was last asked (the database is asked at most once a second)
        self._model_stale: Callable[[], bool] = lambda: False
        self._model_asked: tuple[float, bool] = (-math.inf, False)
        self._last_start: tuple[SourceName, dict[str, Path] | None] | None = None
        self._result_sinks: tuple[ResultSink, ...] = ()
        self._navigation: str | None = None  # the operator's navigation mode, kept over rebuilds
        self._adaptation: OutputAdaptation | None = None  # the running session's teach adaptation
        # the operator holds navigation: now, in every pipeline built later and, through hold_file
        # (beside the database), in the next server process: a crash never releases a hold
        # (a controller session's own hold, _held_for: released when that session stops)
        self._hold_file = hold_file
        self._held, self._held_for = _read_hold(hold_file) if hold_file is not None else (False, None)
        if self._held:
            self._status = replace(self._status, held=True)
            self._snapshot = self._status.to_json()
            log.warning("navigation is held (%s says so): the workstations get still until it is released",
                        hold_file)

    def send_prompt(self, text: str, label: str, remaining_s: float) -> None:
        """A ``prompt`` datagram to the workstations (the recording protocol's instruction)."""
        pipeline = self._pipeline  # one reference read: never waits for a start or stop
        if pipeline is not None:
            pipeline.send_prompt(text, label, remaining_s)

    def set_adaptation(self, adaptation: OutputAdaptation | None) -> None:
        """A participant's teach adaptation of the recogniser (None: none), now and for later pipelines
        (pipeline.takes.teach.OutputAdaptation; issue 18 item 3)."""
        with self._lock:
            self._adaptation = adaptation
            if self._pipeline is not None:
                self._pipeline.set_adaptation(adaptation)

    @property
    def adaptation(self) -> OutputAdaptation | None:
        return self._adaptation

    def set_held(self, held: bool) -> bool:
        """The operator holds navigation (every locomotion datagram says ``still``) or releases it, now
        and for every pipeline built later (``Pipeline.set_held``). A hold the operator asks for is the
        operator's, also one a controller session had set (its stop then leaves it on). Whether it
        changed anything."""
        return self._set_hold(held, "operator", None)

    def hold_for_session(self, session_id: int) -> bool:
        """A controller (``CC``) session starts: navigation is held, as the session's own hold, until
        the session stops (:meth:`release_for_session`) or the operator releases it. A hold that is on
        already stays as it is (the operator's stays the operator's). Whether it changed anything."""
        with self._lock:
            if self._held:
                return False
            return self._set_hold(True, "session", session_id, f"controller session {session_id}")

    def release_for_session(self, session_id: int) -> bool:
        """Session ``session_id`` stopped: its own hold (:meth:`hold_for_session`) is released; any other
        hold (the operator's, or none) is left as it is. Whether it changed anything."""
        with self._lock:
            if not self._held or self._held_for != session_id:
                return False
            return self._set_hold(False, "session", None, f"controller session {session_id} stopped")

    def _set_hold(self, held: bool, by: str, owner: int | None, why: str = "") -> bool:
        """Set the hold (by "operator" or "session"; ``owner``: the session whose own hold it is now),
        record its ``hold`` event now (so it goes to the session running now), keep it in
        ``hold_file``."""
        with self._lock:
            pipeline = self._pipeline
            if pipeline is not None:
                changed = pipeline.set_held(held, by, why)
                for event in pipeline.drain_events():  # now, before a session that stops next leaves
                    self._events.record(*event_fields(event))
            else:
                changed = held != self._held
                if changed or (held and by != self.held_by):  # also the operator taking a session's over
                    message = hold_event_message(held, by, why)
                    self._events.record("hold", {"held": held, "by": by, "message": message})
                    with self._snap_lock:
                        self._status = replace(self._status, held=held)
                        self._snapshot = self._status.to_json()
                    self.refresh()
            kept = (self._held, self._held_for)
            self._held, self._held_for = held, owner if held else None
            if (self._held, self._held_for) != kept:
                self._keep_hold()
        return changed

    def _keep_hold(self) -> None:
        """The hold in ``hold_file`` for the next server process ("held", and "session N" for a
        controller session's own hold; a failure is logged: the hold itself is on or off already)."""
        if self._hold_file is None:
            return
        try:
            if self._held:
                owner = b"" if self._held_for is None else b"session %d\n" % self._held_for
                write_atomic(self._hold_file, b"held\n" + owner)
            else:
                self._hold_file.unlink(missing_ok=True)
        except OSError as exc:
            log.error("the hold could not be kept in %s (%s): a server started again would not know it",
                      self._hold_file, exc)

    @property
    def held_for(self) -> int | None:
        """The controller session whose own hold is on (None: none; the operator's hold, or no hold)."""
        return self._held_for

    @property
    def held_by(self) -> str | None:
        """Whose hold it is: "operator", "session" (a controller session's own), None: not held."""
        if not self._held:
            return None
        return "operator" if self._held_for is None else "session"

    @property
    def held(self) -> bool:
        return self._held

    def video_controls(self) -> dict[str, tuple[VideoControl, float]]:
        """The running pipeline's camera video switches (``Pipeline.video_controls``; {}: none)."""
        pipeline = self._pipeline  # one reference read: no need to wait for a start or stop
        return dict(pipeline.video_controls()) if pipeline is not None else {}

    def add_result_sink(self, sink: ResultSink) -> None:
        """``sink.on_result(FrameResult)`` for every fused frame of this and every later pipeline."""
        with self._lock:
            self._result_sinks = (*self._result_sinks, sink)
            if self._pipeline is not None:
                self._pipeline.add_sink(sink)

    def track_calibration(self, active_id: Callable[[], int | None]) -> None:
        """``active_id()``: the app's active calibration run now; the pipeline is built with it."""
        self._active_calibration = active_id
        self._built_calibration = active_id()

    def track_model(self, stale: Callable[[], bool]) -> None:
        """``stale()``: whether the active action model is another than the pipeline's (one activated
        elsewhere, e.g. by ``cavewalk models ... --activate`` on the same database)."""
        self._model_stale = stale

    def _model_activated_elsewhere(self) -> bool:
        asked_at, stale = self._model_asked
        now = time.monotonic()
        if now - asked_at >= 1.0:
            try:
                stale = self._model_stale()
            except Exception:  # the status goes on without it (asked again in a second)
                log.exception("could not read the active action model")
                stale = False
            self._model_asked = (now, stale)
        return stale

    def calibration_changed(self) -> None:
        """A new calibration is active: the next start builds the pipeline with its cameras (and the
        live status shows the active calibration's id); back to the one the pipeline was built
        with, nothing waits for a restart."""
        with self._lock:
            if self._active_calibration() == self._built_calibration:
                self._rebuild_for.discard("calibration")
            else:
                self._rebuild_for.add("calibration")
        self.refresh()

    def model_changed(self) -> None:
        """Another action model is active: the next start builds the pipeline with it."""
        with self._lock:
            self._rebuild_for.add("model")
        self.refresh()

    def waiting_for_restart(self) -> list[str]:
        """What the running pipeline does not use yet, until it is started again: ``calibration``
        (image sources only: the simulator has its own cameras) and ``model``; [] when stopped."""
        now = self.status()
        if now.state in ("stopped", "unavailable"):
            return []
        pending = set(self._rebuild_for)
        if self._model_activated_elsewhere():
            pending.add("model")
        if now.source == "simulator":
            pending.discard("calibration")
        return sorted(pending)

    def restart(self) -> None:
        """Start again with the last start's source and videos (to take a new calibration or model).
        StateConflict when the pipeline was never started."""
        with self._lock:
            if self._last_start is None:
                raise StateConflict("the pipeline has not been started yet: choose a source and start it")
            source, videos = self._last_start
            self.start(source, videos)

    @property
    def available(self) -> bool:
        return self._factory is not None

    # -- the pushed status (the pipeline's status thread) -----------------------------------
    def on_status(self, pipeline: PipelineFacade, status: PipelineStatus) -> None:
        """A status ``pipeline`` published: kept, its events logged, shown, sent to the sockets."""
        message = status.to_json()
        with self._snap_lock:
            self._status, self._snapshot = status, message
        for event in pipeline.drain_events():
            kind, payload, ts = event_fields(event)
            self._events.record(kind, payload, ts)
        for sink in self._sinks:
            try:
                sink.on_status(status, message)
            except Exception:
                log.exception("live view update failed")
        self.refresh()

    def refresh(self) -> None:
        """The live status or one of the app's own live facts (session, calibration, alarm) changed:
        the WebSockets get it."""
        if self.feed is not None:
            self.feed.publish()

    # -- requests (any thread; never block on the pipeline's work) ------------------------
    def snapshot(self) -> dict[str, Any]:
        """The newest status as JSON (``GET /status`` without the app's own fields)."""
        with self._snap_lock:
            return dict(self._snapshot)

    def status(self) -> PipelineStatus:
        """The newest status."""
        with self._snap_lock:
            return self._status

    def start(self, source: SourceName, videos: dict[str, Path] | None = None) -> None:
        with self._lock:
            if self._factory is None:
                raise PipelineUnavailable(self.unavailable_reason)
            carried = None
            # a rebuild for a new calibration or model, also one activated elsewhere (the command line)
            if self._pipeline is not None and (self._rebuild_for or self._model_stale()):
                carried = self._close_pipeline()
            self._rebuild_for.clear()
            if self._pipeline is None:
                self._built_calibration = self._active_calibration()
                self._pipeline = self._build(self._factory, carried)
                self._model_asked = (-math.inf, False)  # built with the active model: ask afresh
            # (re)start: the pipeline validates first, so a bad request leaves the running one as it was;
            # it reports its own state changes as events, and publishes the status it starts with
            self._pipeline.start(source, videos)
            self._last_start = (source, dict(videos) if videos else None)

    def _build(self, factory: PipelineFactory, carried: Handover | None) -> PipelineFacade:
        """A new pipeline; ``carried``: what the pipeline it replaces hands on (the operator's
        navigation mode and chosen people, the ids given out: a kept choice is nobody, never
        somebody the operator did not choose; the navigator chosen by hand; the stream's seq)."""
        try:
            pipeline = factory(carried)
        except ImportError as exc:
            raise PipelineUnavailable(f"the pipeline cannot be built: {exc}") from exc
        for sink in self._result_sinks:
            pipeline.add_sink(sink)
        if carried is None and self._navigation is not None:  # chosen before any pipeline was built
            pipeline.set_navigation(self._navigation, [])
        if self._adaptation is not None:
            pipeline.set_adaptation(self._adaptation)
        if self._held and not pipeline.held:  # held before any pipeline was built
            session = self._held_for
            if session is None:
                pipeline.set_held(True)
            else:
                pipeline.set_held(True, "session", f"controller session {session}")
        pipeline.subscribe(_Subscription(self, pipeline))
        if self.feed is not None:
            self.feed.own_clock(False)  # the pipeline's statuses set the sockets' rate now
        return pipeline

    def stop(self) -> None:
        with self._lock:
            if self._pipeline is None:
                return
            self._pipeline.stop()  # publishes the stopped status before it returns

    def set_navigator(self, user_id: int | None) -> tuple[int | None, Literal["auto", "manual"]]:
        """Pick the navigator (None = automatic); an id nobody has now raises UnknownUser."""
        with self._lock:
            now = self.status()
            if self._pipeline is None or now.state not in ("running", "starting"):
                if user_id is None:
                    return None, "auto"  # nothing runs: automatic is what it will start with
                raise UnknownUser("the pipeline is not running")
            try:
                self._pipeline.set_navigator(user_id)
            except InputError as exc:  # the pipeline knows who is tracked (TRACKED_WITHIN_S)
                raise UnknownUser(str(exc)) from exc
        mode: Literal["auto", "manual"] = "manual" if user_id is not None else "auto"
        return (user_id if user_id is not None else self.status().navigator), mode

    def set_navigation(self, mode: str, user_ids: list[int]) -> dict[str, Any]:
        """The navigation mode (issue 20) with its chosen people (empty = everyone tracked).
        UnknownUser for an id nobody has now; InputError for a bad mode; nothing changes then."""
        with self._lock:
            now = self.status()
            if user_ids and (self._pipeline is None or now.state not in ("running", "starting")):
                raise UnknownUser(f"no person with user_id {sorted(user_ids)} is tracked now: "
                                  "the pipeline is not running")
            if self._pipeline is not None:
                try:
                    self._pipeline.set_navigation(mode, list(user_ids))
                except InputError as exc:  # the pipeline knows who is tracked (TRACKED_WITHIN_S)
                    if user_ids and "not tracked" in str(exc):
                        raise UnknownUser(str(exc)) from exc
                    raise
            else:  # nothing built yet: the first start takes it
                try:
                    config = NavigationConfig(mode, tuple(user_ids))  # type: ignore[arg-type]
                except ValueError as exc:
                    raise InputError(str(exc)) from None
                with self._snap_lock:
                    self._status = replace(self._status, navigation=NavigationStatus(config.mode))
                    self._snapshot = self._status.to_json()
                self.refresh()
            self._navigation = mode
        return {"mode": mode, "chosen": sorted(user_ids)}  # the fusion worker takes it within a frame

    def snapshot_jpeg(self, camera: str) -> bytes | None:
        pipeline = self._pipeline  # one reference read: no need to wait for a start or stop
        return None if pipeline is None else pipeline.snapshot_jpeg(camera)

    def _close_pipeline(self) -> Handover | None:
        """Stop and close the pipeline; what a pipeline that replaces it carries on."""
        if self._pipeline is None:
            return None
        carried = None
        try:
            carried = self._pipeline.hand_over()  # stops it; with the run's ids and hand-chosen navigator
            self._pipeline.close()
        except Exception:
            log.exception("pipeline stop failed")
        self._pipeline = None
        if self.feed is not None:
            self.feed.own_clock(True)  # no pipeline publishes: the feed keeps the rate
        return carried

    def close(self) -> None:
        """Stop the pipeline (the app's shutdown)."""
        with self._lock:
            self._close_pipeline()
            with self._snap_lock:
                self._status = PipelineStatus("stopped" if self._factory else "unavailable", held=self._held)
                self._snapshot = self._status.to_json()
