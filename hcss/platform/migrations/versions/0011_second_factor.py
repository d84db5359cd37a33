"""A second factor for console sign-in: TOTP secret, last step taken, recovery code hashes.

Written by hand to match `Experimenter` in hcss/platform/models/console.py.
`experimenter` is not append-only, so the batch mode's table copy on SQLite
drops no trigger.

Revision ID: 0011_second_factor
Revises: 0010_return_visit
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0011_second_factor"
down_revision = "0010_return_visit"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("experimenter", schema=None) as batch_op:
        batch_op.add_column(sa.Column("totp_secret", sa.String(length=64), nullable=True))
        batch_op.add_column(sa.Column("totp_last_step", sa.Integer(), nullable=True))
        batch_op.add_column(sa.Column("recovery_hashes", sa.JSON(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("experimenter", schema=None) as batch_op:
        batch_op.drop_column("recovery_hashes")
        batch_op.drop_column("totp_last_step")
        batch_op.drop_column("totp_secret")
