"""The study link's per-client Start windows in the database, so they hold across processes.

Written by hand to match `JoinStart` in hcss/platform/models/join_start.py. The
windows lived in each server process: `hcss serve --processes N` let a client
start N times the limit, and a restart forgot them.

Revision ID: i30_join_start
Revises: i29_group_study
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "i30_join_start"
down_revision = "i29_group_study"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "join_start",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("client", sa.String(length=64), nullable=False),
        sa.Column("at_epoch", sa.Double(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_join_start")),
    )
    op.create_index("ix_join_start_client_at", "join_start", ["client", "at_epoch"])
    op.create_index(op.f("ix_join_start_at_epoch"), "join_start", ["at_epoch"])


def downgrade() -> None:
    op.drop_index(op.f("ix_join_start_at_epoch"), table_name="join_start")
    op.drop_index("ix_join_start_client_at", table_name="join_start")
    op.drop_table("join_start")
