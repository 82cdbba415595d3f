"""Study participants (pseudonymous codes; the first condition is counterbalanced)."""

from __future__ import annotations

from fastapi import APIRouter, status

from app.api.deps import IdPath, SessionDep
from app.api.routes.sessions import session_public
from app.db import repositories as repo
from app.schemas.participants import ParticipantCreate, ParticipantPublic, ParticipantUpdate
from app.schemas.sessions import SessionPublic

router = APIRouter(prefix="/participants", tags=["participants"])


@router.post("", response_model=ParticipantPublic, status_code=status.HTTP_201_CREATED)
def create_participant(body: ParticipantCreate, db: SessionDep) -> ParticipantPublic:
    row = repo.create_participant(db, body.code, body.first_condition, body.notes)
    return ParticipantPublic.model_validate(row)


@router.get("", response_model=list[ParticipantPublic])
def list_participants(db: SessionDep) -> list[ParticipantPublic]:
    return [ParticipantPublic.model_validate(p) for p in repo.list_participants(db)]


@router.get("/{participant_id}", response_model=ParticipantPublic)
def get_participant(participant_id: IdPath, db: SessionDep) -> ParticipantPublic:
    return ParticipantPublic.model_validate(repo.get_participant(db, participant_id))


@router.patch("/{participant_id}", response_model=ParticipantPublic)
def update_participant(participant_id: IdPath, body: ParticipantUpdate, db: SessionDep) -> ParticipantPublic:
    row = repo.update_participant(db, participant_id, body.first_condition, body.notes)
    return ParticipantPublic.model_validate(row)


@router.get("/{participant_id}/sessions", response_model=list[SessionPublic])
def participant_sessions(participant_id: IdPath, db: SessionDep) -> list[SessionPublic]:
    repo.get_participant(db, participant_id)
    return [session_public(s) for s in repo.list_sessions(db, participant_id)]
