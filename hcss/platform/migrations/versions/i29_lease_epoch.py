"""A fencing epoch on each trial lease, raised by every claim.

Written by hand to match `TrialLease` in hcss/platform/models/lease.py.
Existing leases start at epoch 1; `trial_lease` is not append-only.

Revision ID: i29_lease_epoch
Revises: i31a_mturk_submit_to
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "i29_lease_epoch"
down_revision = "i31a_mturk_submit_to"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("trial_lease", schema=None) as batch_op:
        batch_op.add_column(sa.Column("epoch", sa.Integer(), server_default="1", nullable=False))


def downgrade() -> None:
    with op.batch_alter_table("trial_lease", schema=None) as batch_op:
        batch_op.drop_column("epoch")
