"""Calibration runs from the dashboard.

``POST /calibration/runs`` creates a run and returns at once (202); a worker thread
then (1) has the workstations show the wall patterns (served per wall at
``/api/v1/calibration/patterns/{wall}.png``; a ``calibration`` event announces them),
(2) grabs one image per camera (with the simulator source: the simulator's rendered
wall images), (3) runs the PnP calibration of ``pipeline.calibration``, (4) stores
the cameras, per-camera RMS and verdicts and an overlay PNG per camera, and (5) makes
the result the active calibration. Progress and errors are written to the run's row.
"""

from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from sqlalchemy.orm import Session

from app.core.config import Settings
from app.db import repositories as repo
from app.db.models import CalibrationRun
from app.services.event_log import EventWriter
from app.services.live import PipelineService
from pipeline.calibration.overlay import calibration_overlay, encode_png
from pipeline.calibration.patterns import make_layout, render_wall_pattern
from pipeline.calibration.pnp import calibrate_cameras
from pipeline.camera import Camera
from pipeline.errors import CalibrationError, CavewalkError, InputError
from pipeline.sim.scene import default_cameras
from pipeline.sim.walls import render_wall_views
from pipeline.sources import open_source

log = logging.getLogger(__name__)

U8 = NDArray[np.uint8]


def camera_record(cam: Camera, extra: dict[str, Any]) -> dict[str, Any]:
    """One camera of the calibration JSON of SPEC.md, plus the run's per-camera quality fields."""
    return {
        "name": cam.name,
        "image_size": [int(v) for v in cam.image_size],
        "K": np.asarray(cam.K, dtype=float).tolist(),
        "dist": np.asarray(cam.dist, dtype=float).ravel().tolist(),
        "R": np.asarray(cam.R, dtype=float).tolist(),
        "t": np.asarray(cam.t, dtype=float).ravel().tolist(),
        **extra,
    }


class CalibrationService:
    """Runs calibrations in a worker thread and keeps their overlays on disk next to the database."""

    def __init__(
        self,
        settings: Settings,
        session_factory: Callable[[], Session],
        events: EventWriter,
        pipeline: PipelineService,
        viewer: Any = None,
    ) -> None:
        self._settings = settings
        self._factory = session_factory
        self._events = events
        self._pipeline = pipeline
        self._viewer = viewer
        self._cave = settings.cave.geometry()
        self._layout: Any = None
        self._patterns: dict[str, bytes] = {}
        self._sim_images: dict[str, U8] | None = None
        self._lock = threading.Lock()
        self._thread: threading.Thread | None = None
        self.runs_dir = settings.paths.db.parent / "calibration_runs"
        with session_factory() as db:
            active = repo.active_calibration_run(db)
        self.active_id: int | None = active.id if active is not None else None

    # -- wall patterns -----------------------------------------------------------------
    @property
    def walls(self) -> list[str]:
        return [w.name for w in self._cave.walls]

    def layout(self) -> Any:
        with self._lock:
            if self._layout is None:
                self._layout = make_layout(self._cave, self._settings.calibration)
            return self._layout

    def pattern_png(self, wall: str) -> bytes:
        """The PNG a wall's workstation shows during calibration (InputError for an unknown wall)."""
        if wall not in self.walls:
            raise InputError(f"unknown wall {wall!r}; walls are {', '.join(self.walls)}")
        layout = self.layout()
        with self._lock:
            if wall not in self._patterns:
                self._patterns[wall] = encode_png(render_wall_pattern(self._cave, layout, wall))
            return self._patterns[wall]

    # -- runs --------------------------------------------------------------------------
    def start(self) -> CalibrationRun:
        with self._factory() as db:
            run = repo.create_calibration_run(db)  # StateConflict while another run is unfinished
        source = self._pipeline.status().source or "simulator"
        self._thread = threading.Thread(
            target=self._run, args=(run.id, str(source)), name=f"calibration-{run.id}", daemon=True
        )
        self._thread.start()
        return run

    def overlay_path(self, run_id: int, camera: str) -> Path:
        return self.runs_dir / str(run_id) / f"{camera}.png"

    def activate(self, run_id: int) -> CalibrationRun:
        with self._factory() as db:
            run = repo.activate_calibration_run(db, run_id)
        return self._activated(run)

    def compare(self, run_id: int) -> dict[str, Any]:
        """A run's per-camera figures beside the active run's, for the accept step."""
        with self._factory() as db:
            run = repo.get_calibration_run(db, run_id)
            active = repo.active_calibration_run(db)
        if run.status != "done" or run.result is None:
            raise repo.StateConflict(f"calibration run {run_id} is {run.status}: nothing to compare yet")
        ref = active if active is not None and active.id != run.id else None
        ref_cams = {c["name"]: c for c in (ref.result or {}).get("cameras", [])} if ref is not None else {}
        rows = []
        for c in run.result.get("cameras", []):
            old = ref_cams.get(c["name"])
            row: dict[str, Any] = {
                "name": c["name"],
                "new": {k: c.get(k) for k in ("rms_px", "verdict", "markers_used", "walls_seen", "coverage")},
                "active": None,
                "moved_m": None,
                "turned_deg": None,
            }
            if old is not None:
                row["active"] = {
                    k: old.get(k) for k in ("rms_px", "verdict", "markers_used", "walls_seen", "coverage")
                }
                r_new, r_old = np.asarray(c["R"], float), np.asarray(old["R"], float)
                centre = -r_new.T @ np.asarray(c["t"], float)
                centre_old = -r_old.T @ np.asarray(old["t"], float)
                row["moved_m"] = round(float(np.linalg.norm(centre - centre_old)), 4)
                cos = (np.trace(r_new @ r_old.T) - 1.0) / 2.0
                row["turned_deg"] = round(float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))), 3)
            rows.append(row)
        return {
            "run_id": run.id,
            "active_id": ref.id if ref is not None else None,
            "accepted": bool(run.active),
            "cameras": rows,
        }

    def _activated(self, run: CalibrationRun) -> CalibrationRun:
        """What follows a run becoming the active one: the pipeline and the viewer take it."""
        self.active_id = run.id
        self._events.record("calibration", {"state": "activated", "run_id": run.id})
        self._pipeline.calibration_changed()
        self._show_cameras(run)
        return run

    def active_cameras(self) -> list[Camera] | None:
        with self._factory() as db:
            run = repo.active_calibration_run(db)
        return None if run is None or run.result is None else cameras_from_result(run.result)

    def wait(self, timeout_s: float = 30.0) -> None:
        """Wait for the current run's worker (tests, shutdown)."""
        if self._thread is not None:
            self._thread.join(timeout_s)

    def close(self) -> None:
        self.wait(10.0)

    # -- the worker --------------------------------------------------------------------
    def _progress(self, run_id: int, progress: float, message: str, **kw: Any) -> None:
        with self._factory() as db:
            repo.update_calibration_run(db, run_id, progress=progress, message=message, **kw)
        log.info("calibration %d: %.0f%% %s", run_id, 100 * progress, message)

    def _run(self, run_id: int, source: str) -> None:
        t0 = time.monotonic()
        try:
            self._progress(run_id, 0.05, "showing the patterns on the walls", status="running")
            self._events.record(
                "calibration",
                {
                    "state": "patterns",
                    "run_id": run_id,
                    "urls": [f"/api/v1/calibration/patterns/{w}.png" for w in self.walls],
                },
            )
            images = self._grab(source)
            self._progress(run_id, 0.35, f"grabbed {len(images)} camera images; solving")
            result = self._solve(run_id, images)
            rms = {c["name"]: c.get("rms_px") for c in result["cameras"]}
            message = f"done in {time.monotonic() - t0:.1f} s"
            with self._factory() as db:  # done with its result in one commit; the operator accepts it
                repo.finish_calibration_run(db, run_id, f"{message}; review and accept it", result)
            log.info("calibration %d: 100%% %s, waiting for the operator to accept it", run_id, message)
            self._events.record(
                "calibration", {"state": "done", "run_id": run_id, "rms_px": rms, "awaiting": "acceptance"}
            )
        except Exception as exc:  # the worker's boundary: the run fails with the reason
            message = str(exc) if isinstance(exc, CavewalkError) else f"{type(exc).__name__}: {exc}"
            if not isinstance(exc, CavewalkError):
                log.exception("calibration run %d failed", run_id)
            try:
                self._progress(run_id, 1.0, message, status="failed")
            except Exception:
                log.exception("could not store the failure of calibration run %d", run_id)
            self._events.record("calibration", {"state": "failed", "run_id": run_id, "message": message})

    def _grab(self, source: str) -> dict[str, U8]:
        """One image per camera of the walls showing the patterns."""
        if source == "simulator":
            if self._sim_images is None:  # the virtual cameras and walls never move: render once
                sim = self._settings.sim
                cameras = default_cameras(self._cave, sim.camera_preset, 4)  # the simulator source's cameras
                self._sim_images = dict(render_wall_views(self._cave, self.layout(), cameras, seed=sim.seed))
            return dict(self._sim_images)

        images: dict[str, U8] = {}
        for cam in self._settings.cameras:
            src = open_source(cam.source, cam.name)
            try:
                frame = src.read()
            finally:
                src.close()
            if frame is None:
                raise CalibrationError(f"camera {cam.name} delivered no image")
            images[cam.name] = np.asarray(frame.image)
        return images

    def _solve(self, run_id: int, images: dict[str, U8]) -> dict[str, Any]:
        layout = self.layout()
        results = calibrate_cameras(
            {k: [v] for k, v in images.items()}, layout, self._settings.calibration
        )
        out_dir = self.runs_dir / str(run_id)
        out_dir.mkdir(parents=True, exist_ok=True)
        cameras = []
        for name, res in results.items():
            cameras.append(
                camera_record(
                    res.camera,
                    {
                        "rms_px": float(res.rms_px),
                        "verdict": str(res.verdict),
                        "markers_used": int(res.markers_used),
                        "walls_seen": list(res.walls_seen),
                        "coverage": float(res.coverage),
                    },
                )
            )
            self.overlay_path(run_id, name).write_bytes(encode_png(self._overlay(images[name], res)))
        (out_dir / "calibration.json").write_text(json.dumps({"cameras": cameras}, indent=1))
        return {"cameras": cameras}

    def _overlay(self, image: U8, result: Any) -> U8:
        """Detected and reprojected corners, the wall outlines and the CAVE axes on the camera's image."""
        return np.asarray(calibration_overlay(result, self._cave, image), dtype=np.uint8)

    def _show_cameras(self, run: CalibrationRun) -> None:
        if self._viewer is not None and run.result is not None:
            try:
                self._viewer.show_cameras(cameras_from_result(run.result))
            except Exception:
                log.exception("could not show the calibrated cameras")


def cameras_from_result(result: dict[str, Any]) -> list[Camera]:
    cams = []
    for c in result.get("cameras", []):
        cams.append(
            Camera(
                name=c["name"],
                K=np.asarray(c["K"], dtype=np.float64),
                dist=np.asarray(c["dist"], dtype=np.float64),
                R=np.asarray(c["R"], dtype=np.float64),
                t=np.asarray(c["t"], dtype=np.float64),
                image_size=(int(c["image_size"][0]), int(c["image_size"][1])),
            )
        )
    return cams
