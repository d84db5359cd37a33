"""Hardening (issue 13): trial problems; outages on interruption rows.

`trial_problem` holds what a rebuild could not use: a stored command whose
refusal cannot be shown, or a whole trial that could not be loaded (which is
then ended with reason ``rebuild_failed``). Written by hand against
hcss/platform/models/trial.py; the app only ever inserts into it.
`interruption.outage_s` is the wall time the trial clock stood still while
the server was down (hcss/platform/live/outages.py); 0 for older rows.

Revision ID: 0004_h13_hardening
Revises: 0003_study
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004_h13_hardening"
down_revision = "0003_study"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "trial_problem",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("trial_id", sa.Integer(), nullable=False),
        sa.Column("source", sa.String(length=16), nullable=False),
        sa.Column("record", sa.String(length=64), nullable=False),
        sa.Column("problem", sa.String(length=300), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["trial_id"], ["trial.id"], name=op.f("fk_trial_problem_trial_id_trial")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_trial_problem")),
    )
    with op.batch_alter_table("trial_problem", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_trial_problem_trial_id"), ["trial_id"], unique=False)
    with op.batch_alter_table("interruption", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("outage_s", sa.Double(), nullable=False, server_default=sa.text("0"))
        )


def downgrade() -> None:
    with op.batch_alter_table("interruption", schema=None) as batch_op:
        batch_op.drop_column("outage_s")
    with op.batch_alter_table("trial_problem", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_trial_problem_trial_id"))
    op.drop_table("trial_problem")
