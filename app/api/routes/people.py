"""The people tracked now, the primary navigator and the camera snapshots."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Response, status

from app.api.deps import PipelineDep
from app.schemas.live import NavigatorPublic, NavigatorUpdate, PersonPublic
from app.services.live import UnknownUser

router = APIRouter(tags=["people"])


@router.get("/people", response_model=list[PersonPublic])
def people(pipeline: PipelineDep) -> list[PersonPublic]:
    return [PersonPublic.model_validate(p) for p in pipeline.snapshot()["people"]]


@router.get("/navigator", response_model=NavigatorPublic)
def get_navigator(pipeline: PipelineDep) -> NavigatorPublic:
    snap = pipeline.snapshot()
    return NavigatorPublic(navigator=snap["navigator"], mode=snap["navigator_mode"])


@router.put(
    "/navigator",
    response_model=NavigatorPublic,
    responses={404: {"description": "No person with this user id is tracked now"}},
)
def put_navigator(body: NavigatorUpdate, pipeline: PipelineDep) -> NavigatorPublic:
    try:
        navigator, mode = pipeline.set_navigator(body.user_id)
    except UnknownUser as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    return NavigatorPublic(navigator=navigator, mode=mode)


@router.get(
    "/cameras/{camera}/snapshot.jpg",
    response_class=Response,
    responses={200: {"content": {"image/jpeg": {}}}, 404: {"description": "No snapshot of this camera"}},
)
def snapshot(camera: str, pipeline: PipelineDep) -> Response:
    data = pipeline.snapshot_jpeg(camera)
    if data is None:
        raise HTTPException(status.HTTP_404_NOT_FOUND, f"no snapshot of camera {camera!r} yet")
    return Response(data, media_type="image/jpeg", headers={"Cache-Control": "no-store"})
