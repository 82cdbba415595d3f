"""Study sessions: plan, start/stop, notes, exclusion, the event log, questionnaires and participant links.

Questionnaires are scored on submission by ``app.study.questionnaires.score`` and stored with the
raw answers; a bad sheet is a 422 that names every offending item (``items``) in the instrument's
wording. A second entry for the same session, instrument and phase is a 409 unless it is sent as
an explicit correction (``correction_of`` + ``reason``); the design's rules are 409s unless the
operator overrides them (``override_reason``, logged).
"""

from __future__ import annotations

import time
from typing import Annotated, Any

from fastapi import APIRouter, Query, Request, Response, status
from fastapi.responses import JSONResponse

from app.api.deps import EventsDep, IdPath, SessionDep, SettingsDep
from app.core.config import Settings
from app.db import repositories as repo
from app.db.models import StudySession
from app.schemas.participants import ExclusionRequest
from app.schemas.questionnaires import QuestionnaireCreate, QuestionnairePublic
from app.schemas.sessions import EventPublic, SessionCreate, SessionPublic, SessionUpdate
from app.schemas.study import ParticipantLinkPublic, SessionScriptPublic, SessionSummaryPublic
from app.services.participant_link import link_url, qr_svg
from app.study.questionnaires import QuestionnaireError, score
from app.study.session_script import session_script
from app.study.summary import session_summary
from pipeline.recognition.recognizer import DEFAULT_MODEL_PATH

router = APIRouter(prefix="/sessions", tags=["sessions"])

_QUESTIONNAIRE_ERRORS: dict[int | str, dict[str, Any]] = {
    409: {"description": "A duplicate entry (send a correction), or a rule of the study design"},
    422: {"description": "Answers missing, out of range or unknown: every item is named ('items')"},
}


def session_public(row: StudySession) -> SessionPublic:
    out = SessionPublic.model_validate(row)
    out.participant_code = row.participant.code if row.participant is not None else None
    if row.started_at is not None and row.stopped_at is not None:
        out.duration_s = round((row.stopped_at - row.started_at).total_seconds(), 1)
    return out


def questionnaire_public(row: Any) -> QuestionnairePublic:
    out = QuestionnairePublic.model_validate(row)
    out.in_use = repo.in_use(row)
    return out


def questionnaire_error(exc: QuestionnaireError) -> JSONResponse:
    return JSONResponse({"detail": str(exc), "items": list(exc.items)}, status_code=422)


def start_context(request: Request, settings: Settings) -> dict[str, Any]:
    """What a session's start event records: the active calibration, the models, the navigator, and
    whether navigation is held (the operator's hold: the session's summary counts its time)."""
    snap = request.app.state.pipeline.snapshot()
    calibration = request.app.state.calibration
    model = settings.recognition.model_path
    models = getattr(request.app.state, "models", None)
    registry = models.session_context() if models is not None else {}
    return {
        **registry,
        "calibration_id": calibration.active_id,
        "pose_model": settings.pose_model_path.name,
        "action_model": model.name if model != DEFAULT_MODEL_PATH else registry.get(
            "action_model_name", "action.onnx (committed)"),
        "pipeline": snap.get("state"),
        "source": snap.get("source"),
        "navigator": snap.get("navigator"),
        "held": bool(request.app.state.pipeline.held),
    }


@router.post("", response_model=SessionPublic, status_code=status.HTTP_201_CREATED)
def create_session(body: SessionCreate, db: SessionDep) -> SessionPublic:
    change = repo.Change(override=body.override_reason)
    row = repo.create_session(
        db,
        body.participant_id,
        body.condition,
        body.planned_index,
        body.notes,
        change,
        planned_duration_s=body.planned_duration_s,
    )
    return session_public(row)


@router.get("", response_model=list[SessionPublic])
def list_sessions(
    db: SessionDep, participant_id: Annotated[int | None, Query(ge=1, le=2**63 - 1)] = None
) -> list[SessionPublic]:
    return [session_public(s) for s in repo.list_sessions(db, participant_id)]


@router.get("/{session_id}", response_model=SessionPublic)
def get_session(session_id: IdPath, db: SessionDep) -> SessionPublic:
    return session_public(repo.get_session(db, session_id))


@router.patch("/{session_id}", response_model=SessionPublic)
def update_session(session_id: IdPath, body: SessionUpdate, db: SessionDep) -> SessionPublic:
    return session_public(repo.update_session(db, session_id, body.notes, body.planned_duration_s))


@router.post("/{session_id}/start", response_model=SessionPublic)
def start_session(
    session_id: IdPath, request: Request, db: SessionDep, events: EventsDep, settings: SettingsDep
) -> SessionPublic:
    now = time.time()
    code = repo.get_session(db, session_id).participant.code
    models = getattr(request.app.state, "models", None)
    teach = models.teach_context(code) if models is not None else {}
    row = repo.start_session(db, session_id, now, start_context(request, settings) | teach)
    events.set_session(row.id, since_ts=now)
    if row.condition == "CC" and settings.study.hold_controller_sessions:
        request.app.state.pipeline.hold_for_session(row.id)  # the body never moves the walls in CC
    request.app.state.session_timer.schedule(row)
    if models is not None:
        models.session_started(code)  # the participant's teach adaptation (if on) for this session only
    return session_public(row)


@router.post("/{session_id}/stop", response_model=SessionPublic)
def stop_session(session_id: IdPath, request: Request, db: SessionDep, events: EventsDep) -> SessionPublic:
    events.flush()  # the session's last events go to it, not to the next one
    row = repo.stop_session(db, session_id, time.time())
    request.app.state.session_stopped(row.id)  # as the timer's stop: its events still go to the session
    if events.session_id == row.id:
        events.set_session(None)
    request.app.state.session_timer.cancel(row.id)
    return session_public(row)


@router.post("/{session_id}/exclude", response_model=SessionPublic)
def exclude_session(session_id: IdPath, body: ExclusionRequest, db: SessionDep) -> SessionPublic:
    """Leave a session out of the analysis (an aborted run, the wrong condition ...), with a reason."""
    change = repo.Change(actor=body.by or "operator", reason=body.reason)
    return session_public(repo.set_session_excluded(db, session_id, True, change))


@router.post("/{session_id}/include", response_model=SessionPublic)
def include_session(session_id: IdPath, body: ExclusionRequest, db: SessionDep) -> SessionPublic:
    change = repo.Change(actor=body.by or "operator", reason=body.reason)
    return session_public(repo.set_session_excluded(db, session_id, False, change))


@router.delete("/{session_id}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response)
def delete_session(session_id: IdPath, body: ExclusionRequest, db: SessionDep) -> Response:
    """Remove a session planned by mistake (never started); the audit trail keeps what it was."""
    repo.delete_session(db, session_id, repo.Change(actor=body.by or "operator", reason=body.reason))
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/{session_id}/events", response_model=list[EventPublic])
def session_events(
    session_id: IdPath,
    db: SessionDep,
    events: EventsDep,
    kind: Annotated[str | None, Query(max_length=32)] = None,
    since: Annotated[
        float | None, Query(description="Only events at or after this unix time.", allow_inf_nan=False)
    ] = None,
    limit: Annotated[int, Query(ge=1, le=100_000)] = 1000,
) -> list[EventPublic]:
    repo.get_session(db, session_id)
    events.flush()
    rows = repo.list_events(db, session_id=session_id, kind=kind, since_ts=since, limit=limit)
    return [EventPublic.model_validate(e) for e in rows]


@router.get("/{session_id}/summary", response_model=SessionSummaryPublic)
def get_summary(session_id: IdPath, db: SessionDep, events: EventsDep) -> dict[str, Any]:
    """Run time, time without a navigator, gaps in the locomotion stream, actions, questionnaires."""
    events.flush()
    return session_summary(db, session_id)


@router.get("/{session_id}/script", response_model=SessionScriptPublic)
def get_script(session_id: IdPath, db: SessionDep) -> dict[str, Any]:
    """The session script (SSQ pre, the run and its countdown, SSQ post, IPQ, NASA-TLX), each step's state."""
    return session_script(db, repo.get_session(db, session_id))


@router.post(
    "/{session_id}/questionnaires",
    response_model=QuestionnairePublic,
    status_code=status.HTTP_201_CREATED,
    responses=_QUESTIONNAIRE_ERRORS,
)
def submit_questionnaire(
    session_id: IdPath, body: QuestionnaireCreate, db: SessionDep
) -> QuestionnairePublic | JSONResponse:
    change = repo.Change(actor=body.by or "operator", reason=body.reason, override=body.override_reason)
    repo.get_session(db, session_id)  # 404 first; then the sheet (422), then the design's rules (409)
    answers: dict[str, Any] = dict(body.answers)
    pairwise: dict[str, Any] | None = dict(body.pairwise) if body.pairwise is not None else None
    try:
        scores = score(body.instrument, body.phase, answers, pairwise)
    except QuestionnaireError as exc:
        return questionnaire_error(exc)
    row = repo.add_questionnaire(
        db,
        session_id,
        body.instrument,
        body.phase,
        answers,
        pairwise,
        {k: float(v) for k, v in scores.items()},
        change,
        correction_of=body.correction_of,
    )
    return questionnaire_public(row)


@router.get("/{session_id}/questionnaires", response_model=list[QuestionnairePublic])
def list_questionnaires(session_id: IdPath, db: SessionDep) -> list[QuestionnairePublic]:
    return [questionnaire_public(q) for q in repo.list_questionnaires(db, session_id)]


@router.post(
    "/{session_id}/participant-link",
    response_model=ParticipantLinkPublic,
    status_code=status.HTTP_201_CREATED,
)
def create_participant_link(
    session_id: IdPath, request: Request, db: SessionDep, settings: SettingsDep
) -> ParticipantLinkPublic:
    """A link (and QR code) for the participant's tablet, valid for this session only.

    It carries a session-scoped credential, not the operator token; a new link revokes the old one.
    """
    _row, token = repo.create_participant_link(db, session_id)
    url = link_url(settings, request, token)
    return ParticipantLinkPublic(
        session_id=session_id,
        url=url,
        qr_svg=qr_svg(url),
        reachable_from_lan=not url.startswith(("http://127.", "http://localhost")),
    )
