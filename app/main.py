"""The FastAPI application: ``create_app(settings)`` and its lifespan.

The lifespan migrates the SQLite database to the newest Alembic revision, starts
the event-log writer, the one viser server (the 3D view) and the pipeline owner,
and stops them all in reverse order on shutdown. The dashboard (``frontend/``) is
served at ``/``, the API under ``/api/v1``, OpenAPI at ``/docs``, the 3D view at ``/viewer/``
(proxied from the loopback-only viser server, :mod:`app.api.viewer_proxy`).
"""

from __future__ import annotations

import asyncio
import ipaddress
import logging
import secrets
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

from fastapi import FastAPI
from fastapi.middleware.cors import CORSMiddleware
from fastapi.staticfiles import StaticFiles

from app.api.errors import SafeJSONResponse, install_error_handlers
from app.api.fallback import install_api_fallback
from app.api.json_body import JsonBodyGuard
from app.api.limits import BodySizeLimit
from app.api.main import api_router
from app.api.openapi import install_docs
from app.api.origin import SameOriginGuard, allowed_host_names
from app.api.viewer_proxy import router as viewer_router
from app.core.config import Settings, get_settings
from app.db.engine import DatabaseLock, make_engine, make_session_factory
from app.db.migrate import upgrade
from app.db.repositories import fail_unfinished_calibration_runs, running_session
from app.services.backup import BackupService
from app.services.calibration import CalibrationService
from app.services.event_log import EventWriter
from app.services.live import HOLD_FILE, LiveFeed, PipelineFactory, PipelineService, SourceName
from app.services.locomotion_watch import LocomotionWatch
from app.services.models import ModelService
from app.services.pipeline_factory import runtime_factory, simulator_factory
from app.services.planner import PlannerService
from app.services.recorder import RecorderService, takes_folder
from app.services.replay import TakeReplay
from app.services.session_timer import SessionTimer
from app.services.storage import StorageWatch
from app.services.training import TrainingService
from app.viewer import Viewer
from pipeline.calibration.io import calibration_to_dict
from pipeline.runtime.shm import sweep_stale_segments

log = logging.getLogger(__name__)

FRONTEND_DIR = Path(__file__).resolve().parent.parent / "frontend"


def is_loopback(host: str) -> bool:
    if host in ("localhost", ""):
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def operator_token(settings: Settings) -> str | None:
    """The token the API requires: the configured one, a fresh one when bound beyond loopback, else None."""
    if settings.server.token:
        return settings.server.token
    if not is_loopback(settings.server.host):
        return secrets.token_urlsafe(24)
    return None


def _recording_source(pipeline: PipelineService) -> str | None:
    """The running pipeline's source (None when it is not running: nothing to record)."""
    status = pipeline.status()
    return status.source if status.state in ("running", "starting") else None


def _sim_calibration(settings: Settings) -> dict[str, object] | None:
    """The simulator's virtual cameras as a calibration (a simulator take's calibration.json)."""
    try:
        return calibration_to_dict(simulator_factory(settings).cameras)
    except Exception:
        log.exception("the simulator's cameras could not be written with the take")
        return None


def create_app(
    settings: Settings | None = None,
    *,
    autostart: SourceName | None = None,
    pipeline_factory: PipelineFactory | bool | None = True,
    token: str | None = None,
) -> FastAPI:
    """Build the application.

    autostart: start the pipeline with this source once the app is up (``cavewalk demo``).
    pipeline_factory: True = the runtime's ``Pipeline`` built from the settings; None/False = none.
    token: the operator token (default :func:`operator_token`); the ``serve`` command prints it.
    """
    settings = settings or get_settings()
    token = token if token is not None else operator_token(settings)

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[None]:
        db_lock = DatabaseLock.acquire(settings.paths.db)  # one server per database (issue 15 D5)
        backups = BackupService(settings.paths.db, settings.backup)
        backups.before_start()  # a copy of what the last server left, before any migration
        engine = make_engine(settings.paths.db)
        upgrade(engine)
        factory = make_session_factory(engine)
        with factory() as db:
            n = fail_unfinished_calibration_runs(db, "interrupted: the server stopped during the run")
            if n:
                log.warning("%d calibration run(s) left unfinished by the last server were marked failed", n)
            running = running_session(db)
        events = EventWriter(factory, settings.event_log)
        events.start()
        if running is not None:  # a session left running by the last server keeps its log
            events.set_session(
                running.id, since_ts=running.started_at.timestamp() if running.started_at else 0.0
            )
        backups.attach(events)  # a session's end is backed up
        backups.start()
        app.state.backups = backups
        viewer = None
        if settings.server.viser:
            viewer = Viewer.start(settings)
        models = ModelService(settings, factory, events)  # the committed model is the base entry
        app.state.models = models
        if pipeline_factory is True:
            built, reason = runtime_factory(settings, factory, models.recognition_config)
        else:
            built, reason = (pipeline_factory or None), "no pipeline in this app"

        def live_message() -> dict[str, Any]:
            """The live status as the dashboard gets it: the pipeline's newest status (its JSON form)
            and the app's own live facts (running study session, active calibration, alarm)."""
            message = pipeline.snapshot()
            message["held_by"] = pipeline.held_by
            message["running_session_id"] = events.session_id
            message["active_calibration_id"] = calibration.active_id
            message["restart_for"] = pipeline.waiting_for_restart()
            message["alarm"] = watch.current()
            message["storage"] = storage.current()
            return message

        storage = StorageWatch(  # free disk space where the server writes
            {"database": settings.paths.db.parent, "backups": backups.folder,
             "takes": takes_folder(settings)},
            settings.storage,
            events,
            on_change=lambda: feed.publish(),
        )
        backups.refuse_when(storage)  # no backup takes the last space the database needs
        feed = LiveFeed(live_message, settings.server.live_rate_hz)  # the WebSockets' fan-out
        feed.bind(asyncio.get_running_loop())
        watch = LocomotionWatch(events, on_change=feed.publish)
        watch.start()  # raises and logs the alarm even when no status comes
        pipeline = PipelineService(built, events, sinks=(watch, *((viewer,) if viewer else ())), feed=feed,
                                   hold_file=settings.paths.db.parent / HOLD_FILE)
        events.on_session_change(feed.publish)  # a session started or stopped: the dashboard shows it
        if built is None:
            pipeline.unavailable_reason = reason
        models.on_change(pipeline.model_changed)  # a newly active model: rebuilt at the next start
        pipeline.track_model(models.stale)  # ... or one activated on the command line: the top bar says so
        models.on_adaptation(pipeline.set_adaptation)  # teach: while the participant's session runs
        app.state.training = training = TrainingService(settings, factory, models)
        calibration = CalibrationService(settings, factory, events, pipeline, viewer)
        pipeline.track_calibration(lambda: calibration.active_id)
        active = calibration.active_cameras()
        if viewer is not None and active:
            viewer.show_cameras(active)  # the frusta of the active calibration, not the simulator's
        app.state.settings = settings
        app.state.engine = engine
        app.state.session_factory = factory
        app.state.events = events
        app.state.viewer = viewer
        app.state.pipeline = pipeline
        app.state.feed = feed
        app.state.calibration = calibration
        app.state.planner = planner = PlannerService(settings)
        app.state.watch = watch
        recorder = RecorderService(settings, factory, events, source=lambda: _recording_source(pipeline),
                                   sim_calibration=lambda: _sim_calibration(settings),
                                   send_prompt=pipeline.send_prompt, video_controls=pipeline.video_controls,
                                   model=lambda: models.running or models.active(), storage=storage,
                                   waiting=pipeline.waiting_for_restart)
        recorder.recover()  # a take the last server left recording is kept as incomplete
        storage.on_full(recorder.stop_for)  # a full disk ends the take being recorded (it is kept)
        storage.start()
        app.state.storage = storage
        if built is not None:
            sweep_stale_segments()  # the shared memory of a run the last server left crashed
        pipeline.add_result_sink(recorder)
        app.state.recorder = recorder
        app.state.replay = TakeReplay(viewer)
        def session_stopped(session_id: int) -> None:
            """A session stopped (by the operator's route or by its timer): a controller session's own
            hold is released and the participant's teach adaptation comes off."""
            pipeline.release_for_session(session_id)
            models.session_stopped()

        app.state.session_stopped = session_stopped
        session_timer = SessionTimer(factory, events, on_stop=session_stopped)
        app.state.session_timer = session_timer
        left = pipeline.held_for
        if left is not None and (running is None or running.id != left):  # it stopped before a crash
            pipeline.release_for_session(left)
        if running is not None:  # its run time goes on (or is over) across a restart
            with factory() as db:
                again = db.get(type(running), running.id) or running
                session_timer.schedule(again)
                models.session_started(again.participant.code)  # and its participant's adaptation
        events.record(
            "server", {"state": "started", "host": settings.server.host, "port": settings.server.port}
        )
        if autostart is not None:
            try:
                pipeline.start(autostart)
            except Exception as exc:
                log.error("could not start the pipeline (%s): %s", autostart, exc)
                events.record("error", {"where": "pipeline start", "message": str(exc)})
        try:
            yield
        finally:
            storage.close()
            planner.close()
            training.close()
            recorder.close()
            watch.close()
            session_timer.close()
            calibration.close()
            pipeline.close()
            events.record("server", {"state": "stopped"})
            events.close()
            backups.close()  # the last backup holds the last events
            if viewer is not None:
                viewer.stop()
            engine.dispose()
            db_lock.release()

    app = FastAPI(
        title="cavewalk",
        summary="Markerless full-body locomotion for CAVE VR rooms: operator API",
        version="1",
        lifespan=lifespan,
        default_response_class=SafeJSONResponse,
        openapi_url=None,  # served by install_docs, behind the token
        docs_url=None,
        redoc_url=None,
    )
    app.state.token = token
    app.state.settings = settings
    install_error_handlers(app)
    app.include_router(api_router)
    install_docs(app)
    app.include_router(viewer_router)  # the 3D view at /viewer/, behind the token (issue 15 D8)
    install_api_fallback(app)  # after every API route, before the static mount at /
    app.add_middleware(JsonBodyGuard)
    if settings.server.cors_origins:
        app.add_middleware(
            CORSMiddleware,
            allow_origins=list(settings.server.cors_origins),
            allow_methods=["*"],
            allow_headers=["*"],
        )
    app.add_middleware(
        BodySizeLimit,
        max_bytes=settings.server.max_request_bytes,
        upload_paths=(f"{api_router.prefix}/models",),
        upload_bytes=settings.server.max_model_bytes,
    )
    app.add_middleware(  # outermost: Host and Origin before anything reads the request
        SameOriginGuard,
        allowed_hosts=allowed_host_names(settings.server.host, settings.server.allowed_hosts),
        cors_origins=settings.server.cors_origins,
    )
    if FRONTEND_DIR.is_dir():
        app.mount("/", StaticFiles(directory=FRONTEND_DIR, html=True), name="frontend")
    return app
