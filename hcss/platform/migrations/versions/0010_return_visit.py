"""Return visits: an enrolled participant's later visits through the study link, with their ids.

Written by hand to match `ReturnVisit` in hcss/platform/models/recruitment.py;
append-only like `recruitment`, whose first-visit ids it leaves as they were.

Revision ID: 0010_return_visit
Revises: 0009_trial_order
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

revision = "0010_return_visit"
down_revision = "0009_trial_order"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "return_visit",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("participant_id", sa.Integer(), nullable=False),
        sa.Column("recruiter_study_id", sa.String(length=128), nullable=True),
        sa.Column("recruiter_session_id", sa.String(length=128), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["participant_id"],
            ["participant.id"],
            name=op.f("fk_return_visit_participant_id_participant"),
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_return_visit")),
    )
    op.create_index(op.f("ix_return_visit_participant_id"), "return_visit", ["participant_id"])
    for statement in append_only.trigger_statements(op.get_bind().dialect.name, ("return_visit",)):
        op.execute(statement)


def downgrade() -> None:
    for statement in append_only.drop_statements(op.get_bind().dialect.name, ("return_visit",)):
        if "FUNCTION" not in statement:
            op.execute(statement)
    op.drop_index(op.f("ix_return_visit_participant_id"), table_name="return_visit")
    op.drop_table("return_visit")
