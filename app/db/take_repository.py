"""Reading and writing the index of takes (``takes`` table); a rejected change commits nothing."""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from app.db.errors import RecordNotFound
from app.db.models import Take


def create_take(db: Session, **fields: Any) -> Take:
    row = Take(**fields)
    db.add(row)
    db.commit()
    db.refresh(row)
    return row


def get_take(db: Session, take_id: int) -> Take:
    row = db.get(Take, take_id)
    if row is None:
        raise RecordNotFound(f"take {take_id} not found")
    return row


def take_by_uid(db: Session, uid: str) -> Take | None:
    return db.scalars(select(Take).where(Take.uid == uid)).first()


def list_takes(db: Session, participant_code: str | None = None) -> Sequence[Take]:
    q = select(Take).order_by(Take.id)
    if participant_code is not None:
        q = q.where(Take.participant_code == participant_code)
    return db.scalars(q).all()


def unfinished_takes(db: Session) -> Sequence[Take]:
    return db.scalars(select(Take).where(Take.status == "recording").order_by(Take.id)).all()


def finish_take_row(db: Session, take_id: int, manifest: dict[str, Any], status: str) -> Take:
    """Copy a take's final manifest (duration, frames, files) into its row."""
    row = get_take(db, take_id)
    row.status = status
    row.duration_s = manifest.get("duration_s")
    row.frames = int(manifest.get("frames") or 0)
    row.files = dict(manifest.get("files") or {})
    end = manifest.get("end_unix")
    row.ended_at = datetime.fromtimestamp(float(end), UTC) if end else datetime.now(UTC)
    db.commit()
    db.refresh(row)
    return row


def update_take_files(db: Session, take_id: int, files: dict[str, Any]) -> Take:
    row = get_take(db, take_id)
    row.files = dict(files)
    db.commit()
    db.refresh(row)
    return row
