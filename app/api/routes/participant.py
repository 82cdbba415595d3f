"""The participant page's API: what a tablet opened from a session's link may see and send.

Authenticated by the link's session-scoped credential (header ``X-Participant-Token``), never by the
operator token, and only for that session: its questionnaire steps one at a time, the instruments'
own wording, a submission for the step that is due. No scores, no operator data.
"""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Depends, Header, HTTPException, status
from fastapi.responses import JSONResponse
from sqlalchemy.orm import Session

from app.api.deps import SessionDep
from app.db import repositories as repo
from app.db.models import StudySession
from app.schemas.questionnaires import ParticipantSubmission
from app.study.questionnaires import QuestionnaireError, instrument_definitions, score
from app.study.session_script import session_script

router = APIRouter(
    prefix="/participant",
    tags=["participant page"],
    responses={401: {"description": "The participant link is missing, wrong or no longer valid"}},
)

_DENIED = "this link is not valid (any more): ask the experimenter for a new one"


def participant_session(
    db: SessionDep,
    x_participant_token: Annotated[str | None, Header(max_length=128)] = None,
) -> tuple[Session, StudySession, int]:
    found = repo.session_for_link(db, x_participant_token or "")
    if found is None:
        raise HTTPException(status.HTTP_401_UNAUTHORIZED, _DENIED)
    session, link = found
    return db, session, link.id


LinkDep = Annotated[tuple[Session, StudySession, int], Depends(participant_session)]


def _view(db: Session, session: StudySession) -> dict[str, Any]:
    script = session_script(db, session)
    steps = [
        {k: s[k] for k in ("key", "label", "instrument", "phase", "state", "kind") if k in s}
        | ({"remaining_s": s["remaining_s"]} if "remaining_s" in s else {})
        for s in script["steps"]
    ]
    return {
        "session_id": session.id,
        "status": session.status,
        "steps": steps,
        "current": script["current"],
        "complete": script["complete"],
    }


@router.get("/session")
def participant_view(link: LinkDep) -> dict[str, Any]:
    """The session's steps and which one is due (no scores, no participant data)."""
    db, session, _ = link
    return _view(db, session)


@router.get("/instruments")
def participant_instruments(link: LinkDep) -> dict[str, Any]:
    """The instruments of this session's steps, in their own wording."""
    db, session, _ = link
    wanted = {s["instrument"] for s in session_script(db, session)["steps"] if s["instrument"]}
    return {k: v for k, v in instrument_definitions().items() if k in wanted}


@router.post("/questionnaires", status_code=status.HTTP_201_CREATED)
def participant_submit(body: ParticipantSubmission, link: LinkDep) -> Any:
    """Submit the step that is due; the answer is the next state of the page (never the scores)."""
    db, session, link_id = link
    script = session_script(db, session)
    step = next((s for s in script["steps"] if s["key"] == script["current"]), None)
    if step is None:
        raise HTTPException(status.HTTP_409_CONFLICT, "everything is done: please hand the tablet back")
    if step["kind"] == "run":
        raise HTTPException(status.HTTP_409_CONFLICT, "the session is not over yet: please wait")
    if (body.instrument, body.phase) != (step["instrument"], step["phase"]):
        raise HTTPException(
            status.HTTP_409_CONFLICT, f"this is not the questionnaire that is due now ({step['label']})"
        )
    try:
        scores = score(
            body.instrument,
            body.phase,
            dict(body.answers),
            dict(body.pairwise) if body.pairwise is not None else None,
        )
    except QuestionnaireError as exc:
        return JSONResponse({"detail": str(exc), "items": list(exc.items)}, status_code=422)
    repo.add_questionnaire(
        db,
        session.id,
        body.instrument,
        body.phase,
        dict(body.answers),
        dict(body.pairwise) if body.pairwise is not None else None,
        {k: float(v) for k, v in scores.items()},
        repo.Change(actor=f"participant link {link_id}"),
        entered_by="participant",
    )
    db.refresh(session)
    return _view(db, session)
