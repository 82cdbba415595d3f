"""study records: corrections and exclusions with an audit trail, participant links, session script

Revision ID: 0003_study_records
Revises: 0002_events_ts_index
Create Date: 2026-12-01 19:40:00

- participants, study_sessions, questionnaire_responses: ``excluded_at`` / ``exclusion_reason``;
- questionnaire_responses: ``entered_by``, ``corrects_id`` / ``correction_reason`` (an explicit
  correction replaces an earlier entry, which is kept) and ``superseded_by_id``; an older
  database's duplicate entries (same session, instrument and phase) are kept, all but the newest
  marked superseded, as the analysis already used the newest;
- study_sessions: ``planned_duration_s`` (the session script's run time) and ``stopped_by``;
- participants: codes unique ignoring case (``p01`` and ``P01`` are one participant);
- ``audit_log`` (who, when, before, after, why) and ``participant_links`` (hashed credentials).
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0003_study_records"
down_revision: str | None = "0002_events_ts_index"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None

log = logging.getLogger("alembic.runtime.migration")


def upgrade() -> None:
    for table in ("participants", "study_sessions", "questionnaire_responses"):
        with op.batch_alter_table(table) as batch:
            batch.add_column(sa.Column("excluded_at", sa.DateTime(), nullable=True))
            batch.add_column(sa.Column("exclusion_reason", sa.Text(), nullable=True))
    with op.batch_alter_table("study_sessions") as batch:
        batch.add_column(sa.Column("planned_duration_s", sa.Float(), nullable=True))
        batch.add_column(sa.Column("stopped_by", sa.String(16), nullable=True))
    with op.batch_alter_table("questionnaire_responses") as batch:
        batch.add_column(
            sa.Column("entered_by", sa.String(16), nullable=False, server_default="operator")
        )
        batch.add_column(sa.Column("corrects_id", sa.Integer(), nullable=True))
        batch.add_column(sa.Column("correction_reason", sa.Text(), nullable=True))
        batch.add_column(sa.Column("superseded_by_id", sa.Integer(), nullable=True))
        batch.create_foreign_key(
            "fk_questionnaire_responses_corrects_id", "questionnaire_responses", ["corrects_id"], ["id"]
        )
    conn = op.get_bind()
    # duplicates from before: the newest of each (session, instrument, phase) stays in use
    rows = conn.execute(
        sa.text(
            "SELECT id, session_id, instrument, COALESCE(phase, '') FROM questionnaire_responses ORDER BY id"
        )
    ).all()
    newest: dict[tuple[int, str, str], int] = {}
    for rid, sid, instrument, phase in rows:
        key = (sid, instrument, phase)
        if key in newest:
            conn.execute(
                sa.text("UPDATE questionnaire_responses SET superseded_by_id = :new WHERE id = :old"),
                {"new": rid, "old": newest[key]},
            )
        newest[key] = rid
    op.create_table(
        "audit_log",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("at", sa.DateTime(), nullable=False),
        sa.Column("actor", sa.String(64), nullable=False),
        sa.Column("action", sa.String(16), nullable=False),
        sa.Column("entity", sa.String(16), nullable=False),
        sa.Column("entity_id", sa.Integer(), nullable=False),
        sa.Column("before", sa.JSON(), nullable=True),
        sa.Column("after", sa.JSON(), nullable=True),
        sa.Column("reason", sa.Text(), nullable=False),
    )
    op.create_index("ix_audit_log_entity", "audit_log", ["entity", "entity_id"])
    op.create_table(
        "participant_links",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("session_id", sa.Integer(), sa.ForeignKey("study_sessions.id"), nullable=False),
        sa.Column("token_sha256", sa.String(64), nullable=False, unique=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("revoked_at", sa.DateTime(), nullable=True),
    )
    op.create_index("ix_participant_links_session_id", "participant_links", ["session_id"])
    clashes = conn.execute(
        sa.text("SELECT upper(code) FROM participants GROUP BY upper(code) HAVING count(*) > 1")
    ).all()
    if clashes:  # an older database with p01 and P01: kept as they are, new ones are refused by the app
        log.warning(
            "participant codes that differ only in case: %s; rename one (the app refuses new ones)",
            ", ".join(str(c[0]) for c in clashes),
        )
    else:
        op.create_index("ix_participants_code_nocase", "participants", [sa.text("upper(code)")], unique=True)


def downgrade() -> None:
    op.execute("DROP INDEX IF EXISTS ix_participants_code_nocase")
    op.drop_index("ix_participant_links_session_id", table_name="participant_links")
    op.drop_table("participant_links")
    op.drop_index("ix_audit_log_entity", table_name="audit_log")
    op.drop_table("audit_log")
    with op.batch_alter_table("questionnaire_responses") as batch:
        batch.drop_constraint("fk_questionnaire_responses_corrects_id", type_="foreignkey")
        for name in ("superseded_by_id", "correction_reason", "corrects_id", "entered_by"):
            batch.drop_column(name)
    with op.batch_alter_table("study_sessions") as batch:
        batch.drop_column("stopped_by")
        batch.drop_column("planned_duration_s")
    for table in ("participants", "study_sessions", "questionnaire_responses"):
        with op.batch_alter_table(table) as batch:
            batch.drop_column("exclusion_reason")
            batch.drop_column("excluded_at")
