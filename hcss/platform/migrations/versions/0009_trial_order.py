"""Trial orders: console actions for a live trial hosted by another server process.

Written by hand to match `TrialOrder` in hcss/platform/models/order.py. Not
append-only: its host marks an order done.

Revision ID: 0009_trial_order
Revises: 0008_trial_lease
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0009_trial_order"
down_revision = "0008_trial_lease"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "trial_order",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("trial_id", sa.Integer(), nullable=False),
        sa.Column("experimenter_id", sa.Integer(), nullable=True),
        sa.Column("action", sa.String(length=16), nullable=False),
        sa.Column("issued_by", sa.String(length=128), nullable=False),
        sa.Column("done_epoch", sa.Double(), nullable=True),
        sa.Column("outcome", sa.String(length=16), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["trial_id"], ["trial.id"], name=op.f("fk_trial_order_trial_id_trial")
        ),
        sa.ForeignKeyConstraint(
            ["experimenter_id"],
            ["experimenter.id"],
            name=op.f("fk_trial_order_experimenter_id_experimenter"),
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_trial_order")),
    )
    op.create_index(op.f("ix_trial_order_trial_id"), "trial_order", ["trial_id"])
    op.create_index(op.f("ix_trial_order_done_epoch"), "trial_order", ["done_epoch"])


def downgrade() -> None:
    op.drop_index(op.f("ix_trial_order_done_epoch"), table_name="trial_order")
    op.drop_index(op.f("ix_trial_order_trial_id"), table_name="trial_order")
    op.drop_table("trial_order")
