"""Failed console sign-ins in the database, so a restart keeps the lockout (issue 13).

Written by hand to match `LoginFailure` in hcss/platform/models/console.py.
The counts used to live in the server process: a restart forgot them, and
two processes each counted their own.

Revision ID: 0006_issue13_login_attempts
Revises: 0005_a10_vocabularies
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0006_issue13_login_attempts"
down_revision = "0005_a10_vocabularies"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "login_failure",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("scope", sa.String(length=8), nullable=False),
        sa.Column("key", sa.String(length=64), nullable=False),
        sa.Column("at_epoch", sa.Double(), nullable=False),
        sa.Column("locked_until", sa.Double(), nullable=True),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_login_failure")),
    )
    op.create_index("ix_login_failure_scope_key_at", "login_failure", ["scope", "key", "at_epoch"])


def downgrade() -> None:
    op.drop_index("ix_login_failure_scope_key_at", table_name="login_failure")
    op.drop_table("login_failure")
