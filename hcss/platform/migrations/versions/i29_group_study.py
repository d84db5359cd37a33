"""The study files a process group serves (`group_study`), so a process with a different
file refuses to serve.

Written by hand to match `GroupStudy` in hcss/platform/models/group.py; not
append-only (a heartbeat updates it).

Revision ID: i29_group_study
Revises: i29_unique_trial_rows
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "i29_group_study"
down_revision = "i29_unique_trial_rows"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "group_study",
        sa.Column("study", sa.String(length=64), nullable=False),
        sa.Column("digest", sa.String(length=64), nullable=False),
        sa.Column("process", sa.String(length=128), nullable=False),
        sa.Column("seen_epoch", sa.Double(), nullable=False),
        sa.PrimaryKeyConstraint("study", name=op.f("pk_group_study")),
    )


def downgrade() -> None:
    op.drop_table("group_study")
