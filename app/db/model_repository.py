"""Reading and writing the registry of action models (``action_models``) and the participants' teach
adaptations (``adaptations``); a rejected change commits nothing."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from sqlalchemy import select, update
from sqlalchemy.orm import Session

from app.db.errors import RecordNotFound, StateConflict
from app.db.models import ActionModel, Adaptation, utcnow


def list_models(db: Session) -> Sequence[ActionModel]:
    return db.scalars(select(ActionModel).order_by(ActionModel.id)).all()


def get_model(db: Session, model_id: int) -> ActionModel:
    row = db.get(ActionModel, model_id)
    if row is None:
        raise RecordNotFound(f"model {model_id} not found")
    return row


def base_model(db: Session) -> ActionModel | None:
    return db.scalars(select(ActionModel).where(ActionModel.kind == "base")).first()


def active_model(db: Session) -> ActionModel | None:
    return db.scalars(select(ActionModel).where(ActionModel.active.is_(True))).first()


def model_with_sha(db: Session, sha256: str) -> ActionModel | None:
    return db.scalars(select(ActionModel).where(ActionModel.sha256 == sha256)).first()


def add_model(db: Session, **fields: Any) -> ActionModel:
    row = ActionModel(**fields)
    db.add(row)
    db.commit()
    db.refresh(row)
    return row


def make_active(db: Session, model_id: int) -> ActionModel:
    """The model becomes the active one (every other row inactive), in one commit."""
    row = get_model(db, model_id)
    db.execute(update(ActionModel).where(ActionModel.id != row.id).values(active=False))
    row.active = True
    row.activated_at = utcnow()
    db.commit()
    db.refresh(row)
    return row


def previous_model(db: Session) -> ActionModel:
    """The model that was active before the active one (roll back); StateConflict when there is none."""
    current = active_model(db)
    q = select(ActionModel).where(ActionModel.activated_at.is_not(None))
    if current is not None:
        q = q.where(ActionModel.id != current.id)
        if current.activated_at is not None:
            q = q.where(ActionModel.activated_at <= current.activated_at)
    row = db.scalars(q.order_by(ActionModel.activated_at.desc(), ActionModel.id.desc())).first()
    if row is None:
        raise StateConflict("no earlier model to roll back to: only one model was ever active")
    return row


# ----------------------------------------------------------------------------------- adaptations
def add_adaptation(db: Session, **fields: Any) -> Adaptation:
    row = Adaptation(**fields)
    db.add(row)
    db.commit()
    db.refresh(row)
    return row


def get_adaptation(db: Session, adaptation_id: int) -> Adaptation:
    row = db.get(Adaptation, adaptation_id)
    if row is None:
        raise RecordNotFound(f"adaptation {adaptation_id} not found")
    return row


def list_adaptations(db: Session, participant_code: str | None = None) -> Sequence[Adaptation]:
    q = select(Adaptation).order_by(Adaptation.id)
    if participant_code is not None:
        q = q.where(Adaptation.participant_code == participant_code)
    return db.scalars(q).all()


def set_adaptation_enabled(db: Session, adaptation_id: int, enabled: bool) -> Adaptation:
    """Switch an adaptation on (its participant's others off) or off."""
    row = get_adaptation(db, adaptation_id)
    if enabled:
        db.execute(
            update(Adaptation)
            .where(Adaptation.participant_code == row.participant_code, Adaptation.id != row.id)
            .values(enabled=False)
        )
    row.enabled = enabled
    db.commit()
    db.refresh(row)
    return row


def enabled_adaptation(db: Session, participant_code: str, model_id: int) -> Adaptation | None:
    """The participant's adaptation of this model that is switched on (the newest), if any."""
    return db.scalars(
        select(Adaptation)
        .where(
            Adaptation.participant_code == participant_code,
            Adaptation.model_id == model_id,
            Adaptation.enabled.is_(True),
        )
        .order_by(Adaptation.id.desc())
    ).first()
