"""The app's owner of the recognition pipeline.

:class:`PipelineService` holds the runtime's ``Pipeline`` façade (``pipeline.runtime``),
polls it about ten times a second from one background thread, and fans the result
out: the latest status snapshot (for ``GET /status`` and the WebSocket), the 3D view,
and the event log (the pipeline's events go to :class:`~app.services.event_log.EventWriter`,
so a running study session gets every action, navigator and state change).
Requests never wait for the pipeline: they read the snapshot.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Mapping
from enum import Enum
from pathlib import Path
from typing import Any, Literal, Protocol

import numpy as np

from app.services.event_log import EventWriter
from pipeline.errors import InputError

log = logging.getLogger(__name__)

SourceName = Literal["simulator", "cameras", "videos"]


class PipelineUnavailable(RuntimeError):
    """The pipeline cannot be built (its runtime or a part of it is missing)."""


class UnknownUser(LookupError):
    """No tracked person has this user id."""


class PipelineFacade(Protocol):
    """What the app uses of ``pipeline.runtime.Pipeline``."""

    def start(self, source: SourceName, videos: dict[str, Path] | None = None) -> None: ...
    def stop(self) -> None: ...
    def status(self) -> Any: ...
    def set_navigator(self, user_id: int | None) -> None: ...
    def drain_events(self) -> list[Any]: ...
    def snapshot_jpeg(self, camera: str) -> bytes | None: ...
    def send_prompt(self, text: str, label: str, remaining_s: float) -> None: ...


class LiveSink(Protocol):
    """Something that shows each status (the viser 3D view)."""

    def update(self, snapshot: Mapping[str, Any]) -> None: ...


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


def idle_snapshot(state: str = "stopped", source: str | None = None) -> dict[str, Any]:
    return {
        "state": state,
        "source": source,
        "fps": 0.0,
        "dropped": 0,
        "latency_ms": {},
        "cameras": [],
        "people": [],
        "navigator": None,
        "navigator_mode": "auto",
        "navigation": {"mode": "single", "chosen": [], "group": None},
        "action": None,
        "ts": time.time(),
        "extra": {},
    }


def _position(person: Mapping[str, Any]) -> list[float] | None:
    pos = person.get("position_m")
    if pos is None:
        return None
    vals = [float(v) if v is not None else math.nan for v in pos]
    return [round(v, 4) for v in vals] if len(vals) == 3 and all(math.isfinite(v) for v in vals) else None


def _command(c: Mapping[str, Any] | None) -> dict[str, Any] | None:
    """A person's own command (issue 20): label, confidence and the step strip's evidence."""
    if c is None:
        return None
    found = c.get("action")
    action: Mapping[str, Any] = found if isinstance(found, Mapping) else {}
    return {"label": str(c.get("label")), "confidence": float(c.get("confidence") or 0.0),
            "yaw_deg": action.get("yaw_deg"), "speed_mps": action.get("speed_mps"),
            "steps": action.get("steps")}


def _group(g: Any) -> dict[str, Any] | None:
    if not isinstance(g, Mapping):
        return None
    return {"label": str(g.get("label")), "confidence": float(g.get("confidence") or 0.0),
            "members": [int(u) for u in g.get("members") or []],
            "votes": {str(k): int(v) for k, v in (g.get("votes") or {}).items()}}


def status_snapshot(status: Any) -> dict[str, Any]:
    """The runtime's ``PipelineStatus`` -> the JSON object of ``GET /status`` and the WebSocket.

    3D joints (``people3d``) go under ``extra`` for the 3D view and the dashboard's overlay.
    """
    raw = jsonable(status)
    if not isinstance(raw, dict):
        raise TypeError(f"pipeline status must be a dataclass or mapping, got {type(status).__name__}")
    snap = idle_snapshot(str(raw.get("state", "stopped")), raw.get("source"))
    snap["fps"] = float(raw.get("fps") or 0.0)
    snap["dropped"] = int(raw.get("dropped") or 0)
    lat = raw.get("latency_ms") or {}
    snap["latency_ms"] = {
        str(stage): {
            k: (None if v is None else round(float(v), 3))
            for k, v in dict(q).items()
            if k in ("p50", "p95", "p99")
        }
        for stage, q in lat.items()
        if isinstance(q, Mapping)
    }
    snap["cameras"] = [
        {
            "name": str(c.get("name")),
            "ok": bool(c.get("ok")),
            "fps": c.get("fps"),
            "last_error": c.get("last_error"),
        }
        for c in raw.get("cameras") or []
        if isinstance(c, Mapping)
    ]
    navigator = raw.get("navigator")
    snap["navigator"] = None if navigator is None else int(navigator)
    snap["navigator_mode"] = "manual" if raw.get("navigator_mode") == "manual" else "auto"
    found = raw.get("navigation")
    nav: Mapping[str, Any] = found if isinstance(found, Mapping) else {}
    commands = {int(c["user_id"]): c for c in nav.get("commands") or [] if isinstance(c, Mapping)}
    snap["navigation"] = {"mode": str(nav.get("mode") or "single"), "chosen": list(nav.get("chosen") or []),
                          "group": _group(nav.get("group"))}
    snap["people"] = [
        {
            "user_id": int(p["user_id"]),
            "position_m": _position(p),
            "reproj_px": p.get("reproj_px"),
            "is_navigator": snap["navigator"] is not None and int(p["user_id"]) == snap["navigator"],
            "navigating": int(p["user_id"]) in commands,
            "command": _command(commands.get(int(p["user_id"]))),
        }
        for p in raw.get("people") or []
        if isinstance(p, Mapping) and p.get("user_id") is not None
    ]
    action = raw.get("action")
    if isinstance(action, Mapping) and action.get("label") is not None:
        snap["action"] = {
            "label": str(action["label"]),
            "probs": {str(k): float(v or 0.0) for k, v in (action.get("probs") or {}).items()},
            "yaw_deg": action.get("yaw_deg"),
            "speed_mps": action.get("speed_mps"),
            "steps": action.get("steps"),  # step evidence + gate verdict (frontend/js/panels/steps.js)
        }
    people3d = raw.get("people3d")
    if people3d:
        snap["extra"]["people3d"] = people3d
    return snap


#: The runtime's event kinds -> the event log's kinds (others are kept as they are).
EVENT_KINDS = {"state": "pipeline", "worker": "pipeline", "camera": "pipeline"}


def event_fields(event: Any) -> tuple[str, dict[str, Any], float]:
    """A runtime ``PipelineEvent`` (timestamp_s, kind, message, data) -> (kind, payload, unix ts)."""
    raw = jsonable(event)
    if not isinstance(raw, dict):
        return "pipeline", {"value": raw}, time.time()
    kind = str(raw.pop("kind", None) or "pipeline")
    ts_val = raw.pop("timestamp_s", None)
    if ts_val is None:
        ts_val = raw.pop("ts", None)
    data = raw.pop("data", None)
    payload: dict[str, Any] = (
        dict(data) if isinstance(data, dict) else ({} if data is None else {"data": data})
    )
    payload.update(raw)  # message and anything else
    if kind in ("worker", "camera"):
        payload.setdefault("source", kind)
    ts = float(ts_val) if isinstance(ts_val, int | float) and math.isfinite(ts_val) else time.time()
    return EVENT_KINDS.get(kind, kind), payload, ts


class PipelineService:
    """Owns one pipeline (built on first start by ``factory``) and polls it in a thread."""

    def __init__(
        self,
        factory: Callable[[], PipelineFacade] | None,
        events: EventWriter,
        sinks: tuple[LiveSink, ...] = (),
        rate_hz: float = 10.0,
    ) -> None:
        self._factory = factory
        self._events = events
        self._sinks = sinks
        self._period = 1.0 / rate_hz
        self._pipeline: PipelineFacade | None = None
        # _lock serialises the control of the pipeline (start, stop, navigator, rebuild), which may
        # take seconds (spawning or joining workers, on a busy machine many); _snap_lock guards only
        # the latest snapshot, so that status reads (GET /status, every WebSocket message, on the
        # event loop) never wait for a start or stop (issue 15 S3: they did, and timed out)
        self._lock = threading.RLock()
        self._snap_lock = threading.Lock()
        self._snapshot: dict[str, Any] = idle_snapshot("stopped" if factory else "unavailable")
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.unavailable_reason = "" if factory else "the pipeline runtime is not available"
        self._rebuild = False
        self._result_sinks: tuple[Any, ...] = ()
        self._navigation: str | None = None  # the operator's navigation mode, kept over rebuilds
        self._adaptation: Any = None  # the running session's teach adaptation, kept over rebuilds

    def send_prompt(self, text: str, label: str, remaining_s: float) -> None:
        """A ``prompt`` datagram to the workstations (the recording protocol's instruction)."""
        pipeline = self._pipeline  # one reference read: never waits for a start or stop
        if pipeline is not None:
            pipeline.send_prompt(text, label, remaining_s)

    def set_adaptation(self, adaptation: Any) -> None:
        """A participant's teach adaptation of the recogniser (None: none), now and for later pipelines
        (pipeline.takes.teach.OutputAdaptation; issue 18 item 3)."""
        with self._lock:
            self._adaptation = adaptation
            set_adaptation = getattr(self._pipeline, "set_adaptation", None)
            if callable(set_adaptation):
                set_adaptation(adaptation)

    @property
    def adaptation(self) -> Any:
        return self._adaptation

    def video_controls(self) -> dict[str, Any]:
        """The running pipeline's camera video switches (``Pipeline.video_controls``; {}: none)."""
        pipeline = self._pipeline  # one reference read: no need to wait for a start or stop
        get = getattr(pipeline, "video_controls", None)
        return dict(get()) if get is not None else {}

    def add_result_sink(self, sink: Any) -> None:
        """``sink.on_result(FrameResult)`` for every fused frame of this and every later pipeline."""
        with self._lock:
            self._result_sinks = (*self._result_sinks, sink)
            add = getattr(self._pipeline, "add_sink", None)
            if add is not None:
                add(sink)

    def calibration_changed(self) -> None:
        """A new calibration is active: the next start builds the pipeline with its cameras."""
        with self._lock:
            self._rebuild = True

    @property
    def available(self) -> bool:
        return self._factory is not None

    # -- requests (any thread; never block on the pipeline's work) ------------------------
    def snapshot(self) -> dict[str, Any]:
        with self._snap_lock:
            return dict(self._snapshot)

    def start(self, source: SourceName, videos: dict[str, Path] | None = None) -> None:
        with self._lock:
            if self._factory is None:
                raise PipelineUnavailable(self.unavailable_reason)
            if self._pipeline is not None and self._rebuild:
                self._close_pipeline()
            self._rebuild = False
            if self._pipeline is None:
                try:
                    self._pipeline = self._factory()
                except ImportError as exc:
                    raise PipelineUnavailable(f"the pipeline cannot be built: {exc}") from exc
                add = getattr(self._pipeline, "add_sink", None)
                if callable(add):
                    for sink in self._result_sinks:
                        add(sink)
                set_navigation = getattr(self._pipeline, "set_navigation", None)
                if self._navigation is not None and callable(set_navigation):
                    set_navigation(self._navigation, ())  # the chosen ids belong to the last run
                set_adaptation = getattr(self._pipeline, "set_adaptation", None)
                if self._adaptation is not None and callable(set_adaptation):
                    set_adaptation(self._adaptation)
            # (re)start: the pipeline validates first, so a bad request leaves the running one as it was;
            # it reports its own state changes as events
            self._pipeline.start(source, videos)
            self._ensure_thread()
        self.poll_once()

    def stop(self) -> None:
        with self._lock:
            if self._pipeline is None:
                return
            self._pipeline.stop()
        self.poll_once()

    def set_navigator(self, user_id: int | None) -> tuple[int | None, Literal["auto", "manual"]]:
        """Pick the navigator (None = automatic); an id nobody has now raises UnknownUser."""
        with self._lock:
            now = self.snapshot()
            if self._pipeline is None or now["state"] not in ("running", "starting"):
                if user_id is None:
                    return None, "auto"  # nothing runs: automatic is what it will start with
                raise UnknownUser("the pipeline is not running")
            try:
                self._pipeline.set_navigator(user_id)
            except InputError as exc:  # the pipeline knows who is tracked (TRACKED_WITHIN_S)
                raise UnknownUser(str(exc)) from exc
        self.poll_once()
        snap = self.snapshot()
        mode: Literal["auto", "manual"] = "manual" if user_id is not None else "auto"
        return (user_id if user_id is not None else snap["navigator"]), mode

    def set_navigation(self, mode: str, user_ids: list[int]) -> dict[str, Any]:
        """The navigation mode (issue 20) with its chosen people (empty = everyone tracked).
        UnknownUser for an id nobody has now; InputError for a bad mode; nothing changes then."""
        with self._lock:
            now = self.snapshot()
            if user_ids and (self._pipeline is None or now["state"] not in ("running", "starting")):
                raise UnknownUser(f"no person with user_id {sorted(user_ids)} is tracked now: "
                                  "the pipeline is not running")
            set_navigation = getattr(self._pipeline, "set_navigation", None)
            if self._pipeline is not None and callable(set_navigation):
                try:
                    set_navigation(mode, list(user_ids))
                except InputError as exc:  # the pipeline knows who is tracked (TRACKED_WITHIN_S)
                    if user_ids and "not tracked" in str(exc):
                        raise UnknownUser(str(exc)) from exc
                    raise
            else:  # nothing built yet: the first start takes it
                from pipeline.navigation.config import NavigationConfig

                try:
                    NavigationConfig(mode, tuple(user_ids))  # type: ignore[arg-type]
                except ValueError as exc:
                    raise InputError(str(exc)) from None
                with self._snap_lock:
                    self._snapshot["navigation"] = {"mode": mode, "chosen": [], "group": None}
            self._navigation = mode
        self.poll_once()
        return {"mode": mode, "chosen": sorted(user_ids)}  # the fusion worker takes it within a frame

    def snapshot_jpeg(self, camera: str) -> bytes | None:
        pipeline = self._pipeline  # one reference read: no need to wait for a start or stop
        return None if pipeline is None else pipeline.snapshot_jpeg(camera)

    # -- the polling thread ------------------------------------------------------------
    def poll_once(self) -> None:
        """Read the pipeline's status and events once and hand them on."""
        with self._lock:
            pipeline = self._pipeline
        if pipeline is None:
            return
        try:
            snap = status_snapshot(pipeline.status())
            for event in pipeline.drain_events():
                kind, payload, ts = event_fields(event)
                self._events.record(kind, payload, ts)
        except Exception as exc:  # the loop boundary: report, keep serving
            log.exception("pipeline status failed")
            snap = idle_snapshot("error")
            snap["extra"]["error"] = str(exc)
        with self._snap_lock:
            self._snapshot = snap
        for sink in self._sinks:
            try:
                sink.update(snap)
            except Exception:
                log.exception("live view update failed")

    def _ensure_thread(self) -> None:
        if self._thread is None or not self._thread.is_alive():
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="pipeline-poll", daemon=True)
            self._thread.start()

    def _run(self) -> None:
        next_t = time.monotonic()
        while not self._stop.is_set():
            self.poll_once()
            next_t += self._period
            delay = next_t - time.monotonic()
            if delay < 0:
                next_t = time.monotonic()
                delay = 0
            self._stop.wait(delay)

    def _close_pipeline(self) -> None:
        if self._pipeline is None:
            return
        try:
            self._pipeline.stop()
            close = getattr(self._pipeline, "close", None)
            if callable(close):
                close()
        except Exception:
            log.exception("pipeline stop failed")
        self._pipeline = None

    def close(self) -> None:
        """Stop the pipeline and the polling thread (the app's shutdown)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
            self._thread = None
        with self._lock:
            self._close_pipeline()
            with self._snap_lock:
                self._snapshot = idle_snapshot("stopped" if self._factory else "unavailable")
