"""The people tracked now, the primary navigator, the operator's hold and the camera snapshots."""

from __future__ import annotations

from fastapi import APIRouter, HTTPException, Response, status

from app.api.deps import PipelineDep
from app.schemas.live import HoldPublic, HoldUpdate, NavigatorPublic, NavigatorUpdate, PersonPublic
from app.services.live import UnknownUser
from pipeline.errors import InputError

router = APIRouter(tags=["people"])


@router.get("/people", response_model=list[PersonPublic])
def people(pipeline: PipelineDep) -> list[PersonPublic]:
    return [PersonPublic.model_validate(p) for p in pipeline.snapshot()["people"]]


@router.get("/navigator", response_model=NavigatorPublic)
def get_navigator(pipeline: PipelineDep) -> NavigatorPublic:
    snap = pipeline.snapshot()
    nav = snap.get("navigation") or {}
    return NavigatorPublic(navigator=snap["navigator"], mode=snap["navigator_mode"],
                           navigation=nav.get("mode", "single"), user_ids=nav.get("chosen", []))


@router.put(
    "/navigator",
    response_model=NavigatorPublic,
    responses={404: {"description": "No person with this user id is tracked now"},
               400: {"description": "The navigation mode cannot be set"}},
)
def put_navigator(body: NavigatorUpdate, pipeline: PipelineDep) -> NavigatorPublic:
    """Pick the navigator (single mode) or the navigation mode (issue 20: each, group)."""
    try:
        if body.navigation == "single":
            navigator, mode = pipeline.set_navigator(body.user_id)
            chosen = pipeline.set_navigation("single", [])
        else:
            chosen = pipeline.set_navigation(body.navigation, list(body.user_ids or []))
            navigator, mode = pipeline.snapshot()["navigator"], pipeline.snapshot()["navigator_mode"]
    except UnknownUser as exc:
        raise HTTPException(status.HTTP_404_NOT_FOUND, str(exc)) from exc
    except InputError as exc:
        raise HTTPException(status.HTTP_400_BAD_REQUEST, str(exc)) from exc
    return NavigatorPublic(navigator=navigator, mode=mode, navigation=chosen["mode"],
                           user_ids=chosen["chosen"])


@router.get("/navigation/hold", response_model=HoldPublic)
def get_hold(pipeline: PipelineDep) -> HoldPublic:
    return HoldPublic(held=pipeline.held)


@router.put("/navigation/hold", response_model=HoldPublic)
def put_hold(body: HoldUpdate, pipeline: PipelineDep) -> HoldPublic:
    """Hold navigation (``{"held": true}``): from the next datagram on, every locomotion command to the
    workstations says ``still`` (speed 0), in every navigation mode and across restarts of the
    pipeline, until ``{"held": false}`` releases it. The recogniser goes on (the status shows what
    it says, and ``held``); the session's log gets a ``hold`` event for each change."""
    changed = pipeline.set_held(body.held)
    return HoldPublic(held=pipeline.held, changed=changed)


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
