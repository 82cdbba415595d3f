"""Study participants (pseudonymous codes; the first condition is counterbalanced), corrections and
exclusions with a reason (audited), and the audit trail."""

from __future__ import annotations

from typing import Annotated, Literal

from fastapi import APIRouter, Query, Response, status

from app.api.deps import IdPath, SessionDep
from app.api.routes.sessions import questionnaire_public, session_public
from app.db import repositories as repo
from app.schemas.participants import ExclusionRequest, ParticipantCreate, ParticipantPublic, ParticipantUpdate
from app.schemas.questionnaires import AuditPublic, QuestionnairePublic
from app.schemas.sessions import SessionPublic

router = APIRouter(tags=["participants"])


@router.post("/participants", response_model=ParticipantPublic, status_code=status.HTTP_201_CREATED)
def create_participant(body: ParticipantCreate, db: SessionDep) -> ParticipantPublic:
    row = repo.create_participant(db, body.code, body.first_condition, body.notes)
    return ParticipantPublic.model_validate(row)


@router.get("/participants", response_model=list[ParticipantPublic])
def list_participants(db: SessionDep) -> list[ParticipantPublic]:
    return [ParticipantPublic.model_validate(p) for p in repo.list_participants(db)]


@router.get("/participants/{participant_id}", response_model=ParticipantPublic)
def get_participant(participant_id: IdPath, db: SessionDep) -> ParticipantPublic:
    return ParticipantPublic.model_validate(repo.get_participant(db, participant_id))


@router.patch("/participants/{participant_id}", response_model=ParticipantPublic)
def update_participant(participant_id: IdPath, body: ParticipantUpdate, db: SessionDep) -> ParticipantPublic:
    """Notes; the first condition (planned sessions follow; after a session ran only with an
    override); a corrected code (with a reason). Changes are audited."""
    change = repo.Change(actor=body.by or "operator", reason=body.reason, override=body.override_reason)
    row = repo.update_participant(
        db, participant_id, body.first_condition, body.notes, change, code=body.code
    )
    return ParticipantPublic.model_validate(row)


@router.post("/participants/{participant_id}/exclude", response_model=ParticipantPublic)
def exclude_participant(participant_id: IdPath, body: ExclusionRequest, db: SessionDep) -> ParticipantPublic:
    """Leave a participant out of the analysis (withdrew, did not meet a criterion ...), with a reason."""
    change = repo.Change(actor=body.by or "operator", reason=body.reason)
    return ParticipantPublic.model_validate(repo.set_participant_excluded(db, participant_id, True, change))


@router.post("/participants/{participant_id}/include", response_model=ParticipantPublic)
def include_participant(participant_id: IdPath, body: ExclusionRequest, db: SessionDep) -> ParticipantPublic:
    change = repo.Change(actor=body.by or "operator", reason=body.reason)
    return ParticipantPublic.model_validate(repo.set_participant_excluded(db, participant_id, False, change))


@router.delete(
    "/participants/{participant_id}", status_code=status.HTTP_204_NO_CONTENT, response_class=Response
)
def delete_participant(participant_id: IdPath, body: ExclusionRequest, db: SessionDep) -> Response:
    """Remove a participant entered by mistake (none of their sessions ran); the audit trail keeps it."""
    repo.delete_participant(db, participant_id, repo.Change(actor=body.by or "operator", reason=body.reason))
    return Response(status_code=status.HTTP_204_NO_CONTENT)


@router.get("/participants/{participant_id}/sessions", response_model=list[SessionPublic])
def participant_sessions(participant_id: IdPath, db: SessionDep) -> list[SessionPublic]:
    repo.get_participant(db, participant_id)
    return [session_public(s) for s in repo.list_sessions(db, participant_id)]


@router.post("/questionnaires/{questionnaire_id}/exclude", response_model=QuestionnairePublic)
def exclude_questionnaire(
    questionnaire_id: IdPath, body: ExclusionRequest, db: SessionDep
) -> QuestionnairePublic:
    change = repo.Change(actor=body.by or "operator", reason=body.reason)
    return questionnaire_public(repo.set_questionnaire_excluded(db, questionnaire_id, True, change))


@router.post("/questionnaires/{questionnaire_id}/include", response_model=QuestionnairePublic)
def include_questionnaire(
    questionnaire_id: IdPath, body: ExclusionRequest, db: SessionDep
) -> QuestionnairePublic:
    change = repo.Change(actor=body.by or "operator", reason=body.reason)
    return questionnaire_public(repo.set_questionnaire_excluded(db, questionnaire_id, False, change))


@router.get("/audit", response_model=list[AuditPublic], tags=["audit"])
def audit_trail(
    db: SessionDep,
    entity: Annotated[Literal["participant", "session", "questionnaire"] | None, Query()] = None,
    entity_id: Annotated[int | None, Query(ge=1, le=2**63 - 1)] = None,
    limit: Annotated[int, Query(ge=1, le=10_000)] = 1000,
) -> list[AuditPublic]:
    """Every correction, exclusion, deletion and override: who, when, before, after and why (newest first)."""
    return [AuditPublic.model_validate(a) for a in repo.list_audit(db, entity, entity_id, limit)]
