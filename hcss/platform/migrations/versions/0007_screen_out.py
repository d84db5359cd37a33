"""Screen-outs: visitors a study link turned away before consent (the study file's `[requirements]`).

Written by hand to match `ScreenOut` in hcss/platform/models/recruitment.py;
append-only like the other tables of what happened.

Revision ID: 0007_screen_out
Revises: 0006_issue13_login_attempts
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

revision = "0007_screen_out"
down_revision = "0006_issue13_login_attempts"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "screen_out",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("study", sa.String(length=64), nullable=False),
        sa.Column("source", sa.String(length=16), nullable=False),
        sa.Column("recruitment_id", sa.String(length=128), nullable=True),
        sa.Column("width", sa.Integer(), nullable=False),
        sa.Column("height", sa.Integer(), nullable=False),
        sa.Column("mobile", sa.Boolean(), nullable=False),
        sa.Column("missing", sa.String(length=128), nullable=False),
        sa.Column("reasons", sa.String(length=1000), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_screen_out")),
    )
    for statement in append_only.trigger_statements(op.get_bind().dialect.name, ("screen_out",)):
        op.execute(statement)


def downgrade() -> None:
    for statement in append_only.drop_statements(op.get_bind().dialect.name, ("screen_out",)):
        if "FUNCTION" not in statement:
            op.execute(statement)
    op.drop_table("screen_out")
