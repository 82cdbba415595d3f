"""The app's take recorder: takes from the running pipeline, indexed in SQLite.

:class:`RecorderService` is one after-fusion sink of the pipeline (``on_result``); while a take
runs it hands each frame to that take's :class:`~pipeline.takes.recorder.TakeRecorder`, which
writes it into the takes data folder as it goes. The service creates the take's row when it
starts, fills in its files, duration and checksums when it ends, and on the next start
recovers a take a crash left behind as ``incomplete``. It also knows the protocol's current
prompt (the participant page and the workstations' ``prompt`` message).
"""

from __future__ import annotations

import functools
import hashlib
import logging
import re
import secrets
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sqlalchemy.orm import Session

from app.core.config import Settings
from app.db.errors import RecordNotFound, StateConflict
from app.db.models import PARTICIPANT_CODE_PATTERN, StudySession, Take
from app.db.repositories import active_calibration_run
from app.db.take_repository import create_take, finish_take_row, get_take, unfinished_takes
from app.services.event_log import EventWriter
from app.services.storage import StorageWatch
from pipeline.errors import InputError
from pipeline.results import FrameResult
from pipeline.takes.files import recover_take
from pipeline.takes.protocol import (
    LabelSpan,
    Protocol,
    check_margin,
    label_spans,
    load_protocol,
    parse_protocol_text,
    shipped_protocols,
)
from pipeline.takes.recorder import TakeRecorder
from pipeline.takes.video import VideoControl, VideoSession

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class TakeRequest:
    """What a take is asked to be (the API's and the CLI's request)."""

    participant_code: str | None = None
    session_id: int | None = None
    protocol: str | None = None  # a shipped protocol's name (file stem)
    protocol_toml: str | None = None  # or a protocol's TOML text
    duration_s: float | None = None
    margin_s: float | None = None
    lead_s: float | None = None
    notes: str = ""
    videos: bool = False  # one MP4 per camera, written by the capture workers


def takes_folder(settings: Settings) -> Path:
    return settings.takes.folder or settings.paths.db.parent / "takes"


def settings_snapshot(settings: Settings) -> dict[str, Any]:
    """The settings as JSON, without secrets (the operator token)."""
    data = settings.dump()
    data.get("server", {}).pop("token", None)
    return data


def model_identity(path: Path) -> dict[str, Any]:
    try:
        digest = hashlib.sha256(path.read_bytes()).hexdigest()
    except OSError:
        digest = None
    return {"path": str(path), "sha256": digest}


class RecorderService:
    """Records at most one take at a time from the app's pipeline."""

    def __init__(
        self,
        settings: Settings,
        session_factory: Callable[[], Session],
        events: EventWriter,
        source: Callable[[], str | None] = lambda: None,
        sim_calibration: Callable[[], dict[str, Any] | None] = lambda: None,
        send_prompt: Callable[[str, str, float], None] | None = None,
        prompt_period_s: float = 0.5,
        video_controls: Callable[[], dict[str, tuple[VideoControl, float]]] = dict,
        model: Callable[[], dict[str, Any] | None] = lambda: None,
        storage: StorageWatch | None = None,
        waiting: Callable[[], list[str]] = list,
    ) -> None:
        """``model()``: the action model the pipeline runs, as the model registry knows it (its
        ``id``, ``uid``, ``file``...); None = the settings' ``recognition.model_path``. ``storage``:
        no take starts while the disk is full (409). ``waiting()``: what the running pipeline does
        not use yet (``calibration``, ``model``: PipelineService.waiting_for_restart); no take
        starts then (409), since its take.json names the active calibration and model."""
        self.settings = settings
        self._waiting = waiting
        self._storage = storage
        self._model = model
        self.config = settings.takes
        self.folder = takes_folder(settings)
        self._factory = session_factory
        self._events = events
        self._source = source
        self._sim_calibration = sim_calibration
        self._lock = threading.Lock()
        self._current: TakeRecorder | None = None
        self._current_id: int | None = None
        self._send_prompt = send_prompt
        self._prompt_period_s = prompt_period_s
        self._video_controls = video_controls

    # ----------------------------------------------------------------------------- recovery
    def _model_entry(self) -> dict[str, Any]:
        """take.json's ``model``: the file's path and sha256, and the registry's id when it has one."""
        known = self._model()
        if known is None:
            return model_identity(self.settings.recognition.model_path)
        extra = {k: known[k] for k in ("id", "uid", "source") if k in known}
        return model_identity(Path(known["file"])) | {"registry_" + k: v for k, v in extra.items()}

    def recover(self) -> list[int]:
        """Takes the last server left ``recording``: recovered from their folders as ``incomplete``."""
        out = []
        with self._factory() as db:
            for row in unfinished_takes(db):
                try:
                    manifest = recover_take(Path(row.folder))
                except Exception as exc:  # a folder that is gone or unreadable: the row says so
                    log.warning("take %s could not be recovered: %s", row.uid, exc)
                    manifest = {"files": {}, "frames": 0, "duration_s": 0.0}
                    row.notes = (row.notes + f"\nrecovery failed: {exc}").strip()
                finish_take_row(db, row.id, manifest, "incomplete")
                self._events.record(
                    "take",
                    {
                        "state": "recovered",
                        "take_id": row.id,
                        "uid": row.uid,
                        "frames": manifest.get("frames", 0),
                    },
                )
                out.append(row.id)
        if out:
            log.warning("recovered %d take(s) the last server left unfinished: %s", len(out), out)
        return out

    # ------------------------------------------------------------------------------ protocols
    def resolve_protocol(self, name: str | None, toml_text: str | None) -> Protocol | None:
        if name is not None and toml_text is not None:
            raise InputError("give either protocol (a shipped protocol's name) or protocol_toml, not both")
        if toml_text is not None:
            return parse_protocol_text(toml_text, "protocol_toml")
        if name is None:
            return None
        shipped = shipped_protocols()
        if name not in shipped:
            raise InputError(f"unknown protocol {name!r}; shipped protocols: {', '.join(shipped) or 'none'}")
        return load_protocol(shipped[name])

    # ---------------------------------------------------------------------------- start/stop
    def start(self, req: TakeRequest) -> Take:
        """Start a take; bad input raises before anything is stored."""
        protocol = self.resolve_protocol(req.protocol, req.protocol_toml)
        margin = check_margin(self.config.margin_s if req.margin_s is None else req.margin_s)
        lead = check_margin(self.config.lead_s if req.lead_s is None else req.lead_s, "lead_s")
        duration = req.duration_s
        if duration is None and protocol is None:
            raise InputError("a take needs a duration_s or a protocol")
        if duration is not None and (
            isinstance(duration, bool) or not 0 < float(duration) <= self.config.max_duration_s
        ):
            raise InputError(f"duration_s must be in (0, {self.config.max_duration_s:g}], got {duration!r}")
        code = req.participant_code
        if code is not None and not re.match(PARTICIPANT_CODE_PATTERN, code):
            raise InputError(f"participant_code must be 1-32 letters, digits, '_' or '-', got {code!r}")
        if self._storage is not None:
            self._storage.require("a new take")
        source = self._source()
        if source is None:
            raise StateConflict("the pipeline is not running: start it (simulator, cameras or videos) first")
        waiting = self._waiting()
        if waiting:
            new = {"calibration": "the accepted calibration", "model": "the activated action model"}
            what = " and ".join(new.get(w, w) for w in waiting)
            raise StateConflict(f"the running pipeline does not use {what} yet: restart it (Restart now) "
                                "before the take, so that the take holds what it was made with")
        controls = self._video_controls() if req.videos else {}
        if req.videos and not controls:
            raise StateConflict(f"the {source} source has no camera images to record videos of; "
                                "record videos from cameras or video files")
        with self._lock:
            if self._current is not None and not self._current.done:
                raise StateConflict(f"take {self._current_id} is recording; stop it first")
            with self._factory() as db:
                if req.session_id is not None:
                    session = db.get(StudySession, req.session_id)
                    if session is None:
                        raise RecordNotFound(f"study session {req.session_id} not found")
                    if code is None:
                        code = session.participant.code
                run = active_calibration_run(db)
                calibration = run.result if run is not None and source != "simulator" else None
                if source == "simulator":
                    calibration = self._sim_calibration()
                now = datetime.now(UTC)
                uid = f"{now:%Y%m%d-%H%M%S}-{code or 'take'}-{secrets.token_hex(2)}"
                folder = self.folder / uid
                spans: list[LabelSpan] = label_spans(protocol, margin, lead) if protocol is not None else []
                row = create_take(
                    db,
                    uid=uid,
                    folder=str(folder),
                    status="recording",
                    participant_code=code,
                    session_id=req.session_id,
                    protocol=protocol.name if protocol else None,
                    source=source,
                    started_at=now,
                    margin_s=margin if protocol else None,
                    calibration_run_id=run.id if run is not None and source != "simulator" else None,
                    files={},
                    notes=req.notes,
                )
                take_id = row.id
            manifest = {
                "id": uid,
                "take_id": take_id,
                "participant_code": code,
                "session_id": req.session_id,
                "source": source,
                "margin_s": margin,
                "lead_s": lead,
                "notes": req.notes,
                "calibration_id": row.calibration_run_id,
                "model": self._model_entry(),
                "settings": settings_snapshot(self.settings),
            }
            recorder = TakeRecorder(
                folder,
                manifest,
                self.config,
                protocol=protocol,
                spans=spans,
                duration_s=duration,
                calibration=calibration,
                on_done=functools.partial(self._finished, take_id),
                videos=VideoSession(controls, folder / "videos", self.config) if controls else None,
            )
            try:
                recorder.start()
            except Exception:
                with self._factory() as db:  # nothing is left behind for a take that did not start
                    db.delete(get_take(db, take_id))
                    db.commit()
                raise
            self._current, self._current_id = recorder, take_id
            if protocol is not None and self._send_prompt is not None:
                prompts = threading.Thread(target=self._prompts, args=(recorder,), daemon=True)
                prompts.start()
        self._events.record(
            "take",
            {
                "state": "started",
                "take_id": take_id,
                "uid": uid,
                "protocol": row.protocol,
                "participant": code,
            },
        )
        return row

    def stop(self, take_id: int) -> Take:
        with self._factory() as db:
            row = get_take(db, take_id)
        with self._lock:
            recorder = self._current if self._current_id == take_id else None
        if recorder is None or row.status != "recording":
            raise StateConflict(f"take {take_id} is not recording (it is {row.status})")
        recorder.stop()
        with self._factory() as db:
            return get_take(db, take_id)

    def stop_for(self, reason: str) -> int | None:
        """Stop the take being recorded, if any, because of ``reason`` (kept, with what it has; the
        event log says why); its id."""
        with self._lock:
            recorder, take_id = self._current, self._current_id
        if recorder is None or recorder.done or take_id is None:
            return None
        log.warning("take %d stopped: %s", take_id, reason)
        self._events.record("take", {"state": "stopping", "take_id": take_id, "reason": reason})
        recorder.stop()
        return take_id

    def _finished(self, take_id: int, manifest: dict[str, Any]) -> None:
        status = "complete" if manifest.get("complete") else "incomplete"
        with self._factory() as db:
            finish_take_row(db, take_id, manifest, status)
        self._events.record(
            "take",
            {
                "state": status,
                "take_id": take_id,
                "uid": manifest.get("id"),
                "frames": manifest.get("frames"),
                "duration_s": manifest.get("duration_s"),
            },
        )

    def _prompts(self, recorder: TakeRecorder) -> None:
        """The protocol's prompt to the workstations: at each new step, then every ``prompt_period_s``."""
        last_index, last_sent = -1, 0.0
        while not recorder.wait(0.05):
            p = recorder.prompt()
            if p is None:
                continue
            index, step, remaining = p
            now = time.monotonic()
            if index != last_index or now - last_sent >= self._prompt_period_s:
                try:
                    if self._send_prompt is not None:
                        self._send_prompt(step.text, step.label, remaining)
                except Exception:  # the loop boundary: the take goes on without its prompt
                    log.exception("sending the prompt failed")
                last_index, last_sent = index, now

    # ------------------------------------------------------------------------------- the sink
    def on_result(self, result: FrameResult) -> None:
        recorder = self._current
        if recorder is not None and not recorder.done:
            recorder.on_result(result)

    # ---------------------------------------------------------------------------------- state
    def current(self) -> dict[str, Any] | None:
        """The recording take's progress and the protocol's prompt (None: nothing records)."""
        with self._lock:
            recorder, take_id = self._current, self._current_id
        if recorder is None or recorder.done:
            return None
        prompt = recorder.prompt()
        out: dict[str, Any] = {
            "take_id": take_id,
            "uid": recorder.folder.name,
            "elapsed_s": round(recorder.elapsed_s(), 2),
            "duration_s": recorder.duration_s,
            "frames": recorder.written,
            "dropped": recorder.dropped,
            "videos": recorder.videos.stats() if recorder.videos is not None else None,
            "protocol": recorder.protocol.name if recorder.protocol else None,
            "prompt": None,
        }
        if prompt is not None:
            index, step, remaining = prompt
            nxt = (
                recorder.protocol.steps[index + 1]
                if recorder.protocol and index + 1 < len(recorder.protocol.steps)
                else None
            )
            out["prompt"] = {
                "index": index,
                "steps": len(recorder.protocol.steps) if recorder.protocol else 0,
                "text": step.text,
                "label": step.label,
                "tag": step.tag,
                "remaining_s": round(remaining, 2),
                "next": nxt.text if nxt else None,
            }
        return out

    def close(self) -> None:
        """The app's shutdown: a running take ends ``complete`` with what it has."""
        with self._lock:
            recorder = self._current
        if recorder is not None and not recorder.done:
            try:
                recorder.stop()
            except Exception:
                log.exception("stopping the take at shutdown failed")
