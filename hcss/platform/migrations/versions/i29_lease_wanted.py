"""A hand-back request on each trial lease: the process nginx sends the participant to.

Written by hand to match `TrialLease` in hcss/platform/models/lease.py. Both
columns are empty until a process asks for a trial another one holds;
`trial_lease` is not append-only. A running version that does not know the
columns leaves them alone (it never hands a trial back).

Revision ID: i29_lease_wanted
Revises: i30_join_start
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "i29_lease_wanted"
down_revision = "i30_join_start"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("trial_lease", schema=None) as batch_op:
        batch_op.add_column(sa.Column("wanted_by", sa.String(length=128), nullable=True))
        batch_op.add_column(sa.Column("wanted_epoch", sa.Double(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("trial_lease", schema=None) as batch_op:
        batch_op.drop_column("wanted_epoch")
        batch_op.drop_column("wanted_by")
