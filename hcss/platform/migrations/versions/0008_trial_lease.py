"""Trial leases: which server process hosts each live trial (several processes, one database).

Written by hand to match `TrialLease` in hcss/platform/models/lease.py. Not
append-only: a lease is renewed and changes hands.

Revision ID: 0008_trial_lease
Revises: 0007_screen_out
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0008_trial_lease"
down_revision = "0007_screen_out"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "trial_lease",
        sa.Column("trial_id", sa.Integer(), autoincrement=False, nullable=False),
        sa.Column("owner", sa.String(length=128), nullable=False),
        sa.Column("expires_epoch", sa.Double(), nullable=False),
        sa.Column("taken_epoch", sa.Double(), nullable=False),
        sa.PrimaryKeyConstraint("trial_id", name=op.f("pk_trial_lease")),
    )


def downgrade() -> None:
    op.drop_table("trial_lease")
