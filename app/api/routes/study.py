"""The study design: questionnaire definitions, counterbalanced order, gaps and completeness."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Query, status

from app.api.deps import SessionDep, SettingsDep
from app.db import study_repository as study_repo
from app.schemas.study import (
    CompletenessPublic,
    DesignPublic,
    GapWarningPublic,
    InstrumentPublic,
    OrderPublic,
    PlannedParticipant,
    PlanPublic,
    PlanRequest,
)
from app.study.data import load_study
from app.study.design import (
    completeness,
    counterbalanced_orders,
    design_summary,
    gap_warnings,
)
from app.study.questionnaires import instrument_definitions

router = APIRouter(tags=["study"])


@router.get("/questionnaires/instruments", response_model=dict[str, InstrumentPublic])
def instruments() -> dict[str, Any]:
    """Every instrument's items, wording, anchors and ranges (what the questionnaire form shows)."""
    return instrument_definitions()


@router.get("/study/design", response_model=DesignPublic)
def design(db: SessionDep, settings: SettingsDep) -> dict[str, Any]:
    """Counterbalancing so far, the next participant's order, gap warnings and completeness."""
    return design_summary(load_study(db), settings.study.design)


@router.get("/study/order", response_model=list[OrderPublic])
def order(n: Annotated[int, Query(ge=1, le=1000, description="Number of participants.")] = 20) -> list[Any]:
    """A counterbalanced order of conditions for ``n`` participants (half CC first, half EC first)."""
    return [{"participant": i + 1, "order": list(o)} for i, o in enumerate(counterbalanced_orders(n))]


@router.get("/study/completeness", response_model=list[CompletenessPublic])
def study_completeness(db: SessionDep) -> list[dict[str, Any]]:
    """Per participant: conditions without a session and questionnaires still missing."""
    return completeness(load_study(db))


@router.get("/study/warnings", response_model=list[GapWarningPublic])
def study_warnings(db: SessionDep, settings: SettingsDep) -> list[dict[str, Any]]:
    """Sessions of one participant closer together than the minimum gap (study.design.min_gap_days)."""
    cfg = settings.study.design
    return [w.as_dict() for w in gap_warnings(load_study(db), cfg.min_gap_days)]


@router.post("/study/plan", response_model=PlanPublic, status_code=status.HTTP_201_CREATED)
def plan(body: PlanRequest, db: SessionDep) -> PlanPublic:
    """N participants with both sessions planned at once, orders from a Latin square (or given)."""
    planned = study_repo.plan_study(
        db,
        body.participants,
        body.code_prefix,
        body.first_number,
        body.run_minutes * 60.0 if body.run_minutes is not None else None,
        body.first_conditions,
    )
    return PlanPublic(
        participants=[
            PlannedParticipant(participant_id=p.id, code=p.code, order=order,  # type: ignore[arg-type]
                               session_ids=[s.id for s in sessions])
            for p, order, sessions in planned
        ],
        latin_square=study_repo.latin_square(("CC", "EC")),  # type: ignore[arg-type]
        overridden=body.first_conditions is not None,
    )
