"""takes: the index of recorded takes (issue 18)

Revision ID: 0004_takes
Revises: 0003_study_records
Create Date: 2026-12-02 01:00:00

One row per take folder in the takes data folder: participant code, study session, protocol,
source, start/end, duration, frame count, reaction margin, calibration, files with their sha256.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0004_takes"
down_revision: str | None = "0003_study_records"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "takes",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("uid", sa.String(64), nullable=False, unique=True),
        sa.Column("folder", sa.Text(), nullable=False),
        sa.Column("status", sa.String(16), nullable=False, server_default="recording"),
        sa.Column("participant_code", sa.String(32), nullable=True),
        sa.Column("session_id", sa.Integer(), sa.ForeignKey("study_sessions.id"), nullable=True),
        sa.Column("protocol", sa.String(64), nullable=True),
        sa.Column("source", sa.String(16), nullable=True),
        sa.Column("started_at", sa.DateTime(), nullable=False),
        sa.Column("ended_at", sa.DateTime(), nullable=True),
        sa.Column("duration_s", sa.Float(), nullable=True),
        sa.Column("frames", sa.Integer(), nullable=False, server_default="0"),
        sa.Column("margin_s", sa.Float(), nullable=True),
        sa.Column("calibration_run_id", sa.Integer(), nullable=True),
        sa.Column("files", sa.JSON(), nullable=False),
        sa.Column("notes", sa.Text(), nullable=False, server_default=""),
    )
    op.create_index("ix_takes_participant_code", "takes", ["participant_code"])
    op.create_index("ix_takes_session_id", "takes", ["session_id"])


def downgrade() -> None:
    op.drop_index("ix_takes_session_id", table_name="takes")
    op.drop_index("ix_takes_participant_code", table_name="takes")
    op.drop_table("takes")
