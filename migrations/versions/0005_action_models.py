"""action models: the registry of action models and the participants' teach adaptations (issue 18)

Revision ID: 0005_action_models
Revises: 0004_takes
Create Date: 2026-12-04 03:20:00

``action_models``: one row per action model file in the models data folder (the committed model is
the ``base`` row): its kind, file, sha256, its card (JSON and Markdown), the model it was trained
from, whether it is the active one and when it was last activated (roll back = the one before).
``adaptations``: a participant's teach adaptation of one model (the fitted parameters, accuracy
before/after on the held-back part of the teach take), switched on or off.
"""

from __future__ import annotations

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op

revision: str = "0005_action_models"
down_revision: str | None = "0004_takes"
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        "action_models",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("uid", sa.String(64), nullable=False, unique=True),
        sa.Column("name", sa.String(128), nullable=False),
        sa.Column("kind", sa.String(16), nullable=False),
        sa.Column("file", sa.Text(), nullable=False),
        sa.Column("sha256", sa.String(64), nullable=False),
        sa.Column("parent_id", sa.Integer(), sa.ForeignKey("action_models.id"), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("active", sa.Boolean(), nullable=False, server_default=sa.false()),
        sa.Column("activated_at", sa.DateTime(), nullable=True),
        sa.Column("card", sa.JSON(), nullable=False),
        sa.Column("card_md", sa.Text(), nullable=False, server_default=""),
        sa.Column("notes", sa.Text(), nullable=False, server_default=""),
    )
    op.create_table(
        "adaptations",
        sa.Column("id", sa.Integer(), primary_key=True),
        sa.Column("participant_code", sa.String(32), nullable=False),
        sa.Column("model_id", sa.Integer(), sa.ForeignKey("action_models.id"), nullable=False),
        sa.Column("take_id", sa.Integer(), sa.ForeignKey("takes.id"), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.Column("enabled", sa.Boolean(), nullable=False, server_default=sa.true()),
        sa.Column("method", sa.String(32), nullable=False),
        sa.Column("params", sa.JSON(), nullable=False),
        sa.Column("report", sa.JSON(), nullable=False),
    )
    op.create_index("ix_adaptations_participant_code", "adaptations", ["participant_code"])


def downgrade() -> None:
    op.drop_index("ix_adaptations_participant_code", table_name="adaptations")
    op.drop_table("adaptations")
    op.drop_table("action_models")
