"""Study sessions: create, start/stop, notes, the event log, and questionnaire submission.

Questionnaires are scored on submission by ``app.study.questionnaires.score`` (the
study module) and stored with the raw answers; a bad answer is a 422 naming the item.
"""

from __future__ import annotations

import time
from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query, status

from app.api.deps import EventsDep, IdPath, SessionDep
from app.db import repositories as repo
from app.db.models import StudySession
from app.schemas.questionnaires import QuestionnaireCreate, QuestionnairePublic
from app.schemas.sessions import EventPublic, SessionCreate, SessionPublic, SessionUpdate

router = APIRouter(prefix="/sessions", tags=["sessions"])


def session_public(row: StudySession) -> SessionPublic:
    out = SessionPublic.model_validate(row)
    out.participant_code = row.participant.code if row.participant is not None else None
    return out


@router.post("", response_model=SessionPublic, status_code=status.HTTP_201_CREATED)
def create_session(body: SessionCreate, db: SessionDep) -> SessionPublic:
    row = repo.create_session(db, body.participant_id, body.condition, body.planned_index, body.notes)
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
    return session_public(repo.update_session_notes(db, session_id, body.notes))


@router.post("/{session_id}/start", response_model=SessionPublic)
def start_session(session_id: IdPath, db: SessionDep, events: EventsDep) -> SessionPublic:
    now = time.time()
    row = repo.start_session(db, session_id, now)
    events.set_session(row.id, since_ts=now)
    return session_public(row)


@router.post("/{session_id}/stop", response_model=SessionPublic)
def stop_session(session_id: IdPath, db: SessionDep, events: EventsDep) -> SessionPublic:
    events.flush()  # the session's last events go to it, not to the next one
    row = repo.stop_session(db, session_id, time.time())
    if events.session_id == row.id:
        events.set_session(None)
    return session_public(row)


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


@router.post(
    "/{session_id}/questionnaires",
    response_model=QuestionnairePublic,
    status_code=status.HTTP_201_CREATED,
    responses={422: {"description": "An answer is out of range, missing or unknown (the item is named)"}},
)
def submit_questionnaire(
    session_id: IdPath, body: QuestionnaireCreate, db: SessionDep
) -> QuestionnairePublic:
    repo.get_session(db, session_id)
    try:
        from app.study.questionnaires import QuestionnaireError, score
    except ImportError as exc:
        raise HTTPException(
            status.HTTP_503_SERVICE_UNAVAILABLE, "questionnaire scoring is not installed"
        ) from exc
    answers: dict[str, Any] = dict(body.answers)
    pairwise: dict[str, Any] | None = dict(body.pairwise) if body.pairwise is not None else None
    try:
        scores = score(body.instrument, body.phase, answers, pairwise)
    except QuestionnaireError as exc:
        item = getattr(exc, "item", None)
        message = str(exc) if item is None or str(item) in str(exc) else f"{item}: {exc}"
        raise HTTPException(status.HTTP_422_UNPROCESSABLE_CONTENT, message) from exc
    row = repo.add_questionnaire(
        db,
        session_id,
        body.instrument,
        body.phase,
        answers,
        pairwise,
        {k: float(v) for k, v in scores.items()},
    )
    return QuestionnairePublic.model_validate(row)


@router.get("/{session_id}/questionnaires", response_model=list[QuestionnairePublic])
def list_questionnaires(session_id: IdPath, db: SessionDep) -> list[QuestionnairePublic]:
    return [QuestionnairePublic.model_validate(q) for q in repo.list_questionnaires(db, session_id)]
