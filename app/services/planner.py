"""Camera-coverage plans for the command line and the dashboard.

The camera sets a plan can take: a calibration file (JSON, Pose2Sim TOML, Qualisys qca), a proposed
set sent as calibration JSON, the active calibration, the simulator's default layout; or a camera
count for the mount search. :class:`PlannerService` runs the API's plans one at a time in a worker
thread (``POST /api/v1/plan`` answers 202 with a job id) and keeps the last few jobs' numbers and
figures in memory: a plan is cheap to make again, so nothing is stored in the database.
"""

from __future__ import annotations

import logging
import threading
import time
from collections import OrderedDict
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from typing import Any, Literal

from app.core.config import Settings
from pipeline.calibration.io import cameras_from_dict
from pipeline.camera import Camera
from pipeline.errors import CavewalkError, InputError
from pipeline.planner.config import PlannerConfig, SearchConfig
from pipeline.planner.plan import make_plan
from pipeline.planner.room import check_cameras, floor_polygon
from pipeline.planner.search import check_search
from pipeline.sim.scene import default_cameras

log = logging.getLogger(__name__)

JobStatus = Literal["pending", "running", "done", "failed"]
KEEP_JOBS = 8


def default_layout(settings: Settings, count: int | None = None) -> list[Camera]:
    """The simulator's cameras (one above each wall, then the corners) for ``count`` cameras (default 4)."""
    return list(default_cameras(settings.cave.geometry(), settings.sim.camera_preset, count or 4))


def planner_config(settings: Settings, **overrides: Any) -> PlannerConfig:
    """The planner's config from the settings, with overrides (None = keep the setting)."""
    return replace(settings.planner, **{k: v for k, v in overrides.items() if v is not None})


def mount_search(settings: Settings, count: int, preset: str, **overrides: Any) -> SearchConfig:
    """The mount search's config for ``count`` cameras of the ``preset`` model (None = keep the setting)."""
    changes = {k: v for k, v in overrides.items() if v is not None}
    return replace(settings.planner.search, count=count, preset=preset, **changes)


def run_plan(
    settings: Settings,
    *,
    cameras: Sequence[Camera] | None = None,
    count: int | None = None,
    source: str = "",
    overrides: dict[str, Any] | None = None,
    progress: Callable[[float, str], None] | None = None,
) -> Any:
    """A :class:`pipeline.planner.plan.Plan` of ``cameras`` or of a mount search for ``count`` cameras."""
    o = dict(overrides or {})
    top_k = o.pop("top_k", None)
    preset = o.pop("preset", None) or settings.sim.camera_preset
    cfg = planner_config(settings, **o)
    cave = settings.cave.geometry()
    if count is not None:
        search = mount_search(settings, count, preset, top_k=top_k)
        reference = default_layout(settings, count) if count <= 8 else None
        return make_plan(
            cave,
            count=count,
            planner=cfg,
            search=search,
            default_cameras=reference,
            source=source or f"mount search for {count} cameras",
            progress=progress,
        )
    return make_plan(cave, cameras=cameras, planner=cfg, source=source, progress=progress)


class PlanBusy(CavewalkError):
    """Another plan is still being made."""


@dataclass
class PlanJob:
    """One plan of the API: its state, and when done its numbers and figures (name.fmt -> bytes)."""

    id: int
    source: str
    created_at: datetime
    status: JobStatus = "pending"
    progress: float = 0.0
    message: str = "waiting"
    result: dict[str, Any] | None = None
    figures: dict[str, bytes] = field(default_factory=dict)
    elapsed_s: float | None = None


class PlannerService:
    """Makes the API's plans in a worker thread, one at a time; keeps the last ``KEEP_JOBS``."""

    def __init__(self, settings: Settings) -> None:
        self._settings = settings
        self._lock = threading.Lock()
        self._jobs: OrderedDict[int, PlanJob] = OrderedDict()
        self._next_id = 1
        self._thread: threading.Thread | None = None

    def start(
        self, *, cameras: Sequence[Camera] | None, count: int | None, source: str, overrides: dict[str, Any]
    ) -> PlanJob:
        """Check the input (InputError before any job exists) and start the plan; PlanBusy while one runs."""
        room = floor_polygon(self._settings.cave.geometry())
        cfg = planner_config(
            self._settings, **{k: v for k, v in overrides.items() if k not in ("top_k", "preset")}
        )
        if cameras is not None:
            check_cameras(room, list(cameras), above_walls_m=cfg.above_walls_m)
        else:
            check_search(
                room,
                mount_search(
                    self._settings,
                    count if count is not None else 0,
                    overrides.get("preset") or self._settings.sim.camera_preset,
                ),
            )
        with self._lock:
            if self._thread is not None and self._thread.is_alive():
                raise PlanBusy("a plan is still being made; wait for it to finish")
            job = PlanJob(self._next_id, source, datetime.now(UTC))
            self._next_id += 1
            self._jobs[job.id] = job
            while len(self._jobs) > KEEP_JOBS:
                self._jobs.popitem(last=False)
            self._thread = threading.Thread(
                target=self._run, args=(job, cameras, count, overrides), name=f"plan-{job.id}", daemon=True
            )
            self._thread.start()
        return job

    def get(self, job_id: int) -> PlanJob | None:
        with self._lock:
            return self._jobs.get(job_id)

    def jobs(self) -> list[PlanJob]:
        with self._lock:
            return list(reversed(self._jobs.values()))

    def wait(self, timeout_s: float = 120.0) -> None:
        """Wait for the current plan (tests, shutdown)."""
        thread = self._thread
        if thread is not None:
            thread.join(timeout_s)

    def close(self) -> None:
        self.wait(5.0)

    def _update(self, job: PlanJob, **changes: Any) -> None:
        with self._lock:
            for k, v in changes.items():
                setattr(job, k, v)

    def _run(
        self, job: PlanJob, cameras: Sequence[Camera] | None, count: int | None, overrides: dict[str, Any]
    ) -> None:
        t0 = time.monotonic()
        self._update(job, status="running", progress=0.02, message="starting")
        try:
            plan = run_plan(
                self._settings,
                cameras=cameras,
                count=count,
                source=job.source,
                overrides=overrides,
                progress=lambda f, m: self._update(job, progress=min(0.95, 0.9 * f), message=m),
            )
            self._update(job, progress=0.95, message="drawing the figures")
            from pipeline.planner.figures import figure_files, render  # matplotlib: ~0.4 s of every start

            figures = {
                f"{name}.{fmt}": render(fig, fmt)
                for name, fig in figure_files(plan.coverage, plan.search).items()
                for fmt in ("png", "svg")
            }
            result = plan.to_dict()
            elapsed = time.monotonic() - t0
            self._update(
                job,
                status="done",
                progress=1.0,
                message=f"done in {elapsed:.1f} s",
                result=result,
                figures=figures,
                elapsed_s=elapsed,
            )
            log.info("plan %d (%s): done in %.1f s", job.id, job.source, elapsed)
        except Exception as exc:  # the worker's boundary: the job fails with the reason
            message = str(exc) if isinstance(exc, CavewalkError) else f"{type(exc).__name__}: {exc}"
            if not isinstance(exc, CavewalkError):
                log.exception("plan %d failed", job.id)
            self._update(job, status="failed", progress=1.0, message=message)


def cameras_from_json(data: object) -> list[Camera]:
    """A proposed camera set in the calibration JSON of SPEC.md (InputError when malformed or empty)."""
    if isinstance(data, dict) and isinstance(data.get("cameras"), list) and not data["cameras"]:
        raise InputError("the proposed camera set has zero cameras")
    return cameras_from_dict(data, "proposed cameras")
