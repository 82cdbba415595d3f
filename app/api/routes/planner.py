"""Camera-coverage plans: start one (202 + job id), follow it, fetch its numbers and figures."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, HTTPException, Path, Response, status

from app.api.deps import CalibrationDep, IdPath, PlannerDep, SettingsDep
from app.schemas.planner import PlanCreate, PlanJobAccepted, PlanJobPublic
from app.services.planner import PlanBusy, PlanJob, cameras_from_json, default_layout

router = APIRouter(prefix="/plan", tags=["planner"])

FIGURE_TYPES = {"png": "image/png", "svg": "image/svg+xml"}


def job_public(job: PlanJob, with_result: bool = True) -> PlanJobPublic:
    return PlanJobPublic(
        id=job.id,
        created_at=job.created_at,
        source=job.source,
        status=job.status,
        progress=job.progress,
        message=job.message,
        elapsed_s=job.elapsed_s,
        figures=[f"/api/v1/plan/{job.id}/figures/{name}" for name in sorted(job.figures)],
        result=job.result if with_result else None,
    )


@router.post("", response_model=PlanJobAccepted, status_code=status.HTTP_202_ACCEPTED)
def start_plan(
    body: PlanCreate, planner: PlannerDep, calibration: CalibrationDep, settings: SettingsDep
) -> PlanJobAccepted:
    """Start a plan; bad input (walls that do not close, a camera outside the room, zero cameras,
    malformed calibration JSON) is refused here with 422, before any job exists."""
    cameras = None
    count = None
    if body.source != "proposed" and body.calibration is not None:
        raise HTTPException(422, "'calibration' goes with source 'proposed' only")
    if body.source != "search" and body.count is not None:
        raise HTTPException(422, "'count' goes with source 'search' only")
    if body.source == "search":
        if body.count is None:
            raise HTTPException(422, "source 'search' needs 'count': how many cameras to place")
        count = body.count
        source = f"mount search for {count} cameras"
    elif body.source == "proposed":
        if body.calibration is None:
            raise HTTPException(422, "source 'proposed' needs 'calibration': the cameras as calibration JSON")
        cameras = cameras_from_json(body.calibration)
        source = f"proposed set of {len(cameras)} cameras"
    elif body.source == "active":
        active = calibration.active_cameras()
        if not active:
            raise HTTPException(
                status.HTTP_409_CONFLICT,
                "no calibration is active yet: calibrate first, or plan the default layout or a proposed set",
            )
        cameras = active
        source = f"active calibration (run {calibration.active_id})"
    else:
        cameras = default_layout(settings)
        source = f"default layout ({settings.sim.camera_preset})"
    overrides = {
        "grid_step_m": body.grid_step_m,
        "samples": body.samples,
        "seed": body.seed,
        "top_k": body.top_k,
    }
    try:
        job = planner.start(cameras=cameras, count=count, source=source, overrides=overrides)
    except PlanBusy as exc:
        raise HTTPException(status.HTTP_409_CONFLICT, str(exc)) from exc
    return PlanJobAccepted(id=job.id, status=job.status, status_url=f"/api/v1/plan/{job.id}")


@router.get("", response_model=list[PlanJobPublic])
def list_plans(planner: PlannerDep) -> list[PlanJobPublic]:
    """The last plans, newest first (without their numbers)."""
    return [job_public(j, with_result=False) for j in planner.jobs()]


@router.get("/{job_id}", response_model=PlanJobPublic)
def get_plan(job_id: IdPath, planner: PlannerDep) -> PlanJobPublic:
    job = planner.get(job_id)
    if job is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no plan {job_id} (the last few are kept)")
    return job_public(job)


@router.get(
    "/{job_id}/figures/{name}.{fmt}",
    response_class=Response,
    responses={
        200: {"content": {"image/png": {}, "image/svg+xml": {}}},
        404: {"description": "No such figure"},
    },
)
def figure(
    job_id: IdPath,
    name: Annotated[str, Path(pattern=r"^[a-z_]{1,32}$")],
    fmt: Literal["png", "svg"],
    planner: PlannerDep,
) -> Response:
    job = planner.get(job_id)
    if job is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no plan {job_id}")
    data = job.figures.get(f"{name}.{fmt}")
    if data is None:
        have = ", ".join(sorted(job.figures)) or "none yet"
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"plan {job_id} has no figure {name}.{fmt} ({have})")
    return Response(data, media_type=FIGURE_TYPES[fmt])
