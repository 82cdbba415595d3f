"""Calibration runs: trigger (202 + job id), progress, per-camera RMS, overlays, history, roll back.

The wall patterns the workstations show are served per wall.
"""

from __future__ import annotations

from typing import Any

from fastapi import APIRouter, HTTPException, Response, status
from fastapi.responses import FileResponse

from app.api.deps import CalibrationDep, IdPath, SessionDep
from app.db import repositories as repo
from app.db.models import CalibrationRun
from app.schemas.calibration import (
    CalibrationCameraPublic,
    CalibrationComparePublic,
    CalibrationJobAccepted,
    CalibrationRunPublic,
)
from pipeline.errors import InputError

router = APIRouter(prefix="/calibration", tags=["calibration"])


def run_public(row: CalibrationRun, with_result: bool = False) -> CalibrationRunPublic:
    cams = []
    if row.result:
        for c in row.result.get("cameras", []):
            cams.append(
                CalibrationCameraPublic(
                    name=str(c.get("name")),
                    rms_px=c.get("rms_px"),
                    verdict=c.get("verdict"),
                    markers_used=c.get("markers_used"),
                    walls_seen=list(c.get("walls_seen") or []),
                )
            )
    return CalibrationRunPublic(
        id=row.id,
        created_at=row.created_at,
        status=row.status,  # type: ignore[arg-type]
        progress=row.progress,
        message=row.message,
        active=row.active,
        cameras=cams,
        result=row.result if with_result else None,
    )


@router.get("/walls", response_model=list[str])
def walls(calibration: CalibrationDep) -> list[str]:
    return calibration.walls


@router.get(
    "/patterns/{wall}.png",
    response_class=Response,
    responses={200: {"content": {"image/png": {}}}, 404: {"description": "Unknown wall"}},
)
def pattern(wall: str, calibration: CalibrationDep) -> Response:
    """The ArUco pattern image a wall's workstation shows (full wall, at the wall's resolution)."""
    try:
        png = calibration.pattern_png(wall)
    except InputError as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    return Response(png, media_type="image/png")


@router.post("/runs", response_model=CalibrationJobAccepted, status_code=status.HTTP_202_ACCEPTED)
def start_run(calibration: CalibrationDep) -> CalibrationJobAccepted:
    run = calibration.start()
    return CalibrationJobAccepted(
        id=run.id, status="pending", status_url=f"/api/v1/calibration/runs/{run.id}"
    )


@router.get("/runs", response_model=list[CalibrationRunPublic])
def list_runs(db: SessionDep) -> list[CalibrationRunPublic]:
    return [run_public(r) for r in repo.list_calibration_runs(db)]


@router.get("/active", response_model=CalibrationRunPublic)
def active_run(db: SessionDep) -> CalibrationRunPublic:
    row = repo.active_calibration_run(db)
    if row is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "no calibration is active yet")
    return run_public(row, with_result=True)


@router.get("/runs/{run_id}", response_model=CalibrationRunPublic)
def get_run(run_id: IdPath, db: SessionDep) -> CalibrationRunPublic:
    return run_public(repo.get_calibration_run(db, run_id), with_result=True)


@router.post("/runs/{run_id}/activate", response_model=CalibrationRunPublic)
def activate_run(run_id: IdPath, calibration: CalibrationDep) -> CalibrationRunPublic:
    """Accept a finished run (a new run is not used until it is accepted), or roll back to an earlier one."""
    return run_public(calibration.activate(run_id), with_result=True)


@router.get("/runs/{run_id}/compare", response_model=CalibrationComparePublic)
def compare_run(run_id: IdPath, calibration: CalibrationDep) -> dict[str, Any]:
    """The run's per-camera figures beside the active run's (RMS, markers, walls, how far each camera
    moved and turned): what the operator looks at before accepting it."""
    return calibration.compare(run_id)


@router.get(
    "/runs/{run_id}/overlays/{camera}.png",
    response_class=FileResponse,
    responses={200: {"content": {"image/png": {}}}, 404: {"description": "No overlay for this camera"}},
)
def overlay(run_id: IdPath, camera: str, db: SessionDep, calibration: CalibrationDep) -> FileResponse:
    row = repo.get_calibration_run(db, run_id)
    names = [str(c.get("name")) for c in (row.result or {}).get("cameras", [])]
    if camera not in names:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"run {run_id} has no camera {camera!r} (has {names})")
    path = calibration.overlay_path(run_id, camera)
    if not path.is_file():
        raise HTTPException(
            status.HTTP_404_NOT_FOUND, f"the overlay of {camera!r} in run {run_id} is missing"
        )
    return FileResponse(path, media_type="image/png")
