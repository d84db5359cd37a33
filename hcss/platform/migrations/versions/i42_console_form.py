"""The console's Create forms, once carried out (`console_form`): a key each, unique.

Written by hand to match `ConsoleForm` in hcss/platform/models/console.py. A Create
sent twice (a double click past the page, a resend, a proxy's retry) made two
batches of links; the unique key lets the server answer a repeat with the first
batch and make nothing. Append-only, as `command_key` (the participant's commands'
keys) is: a form carried out is a record of what happened.

Revision ID: i42_console_form
Revises: i41p_placement_snapshots
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

revision = "i42_console_form"
down_revision = "i41p_placement_snapshots"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "console_form",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("key", sa.String(length=64), nullable=False),
        sa.Column("experimenter_id", sa.Integer(), nullable=True),
        sa.Column("batch", sa.String(length=32), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["experimenter_id"],
            ["experimenter.id"],
            name=op.f("fk_console_form_experimenter_id_experimenter"),
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_console_form")),
        sa.UniqueConstraint("key", name=op.f("uq_console_form_key")),
    )
    for statement in append_only.trigger_statements(op.get_bind().dialect.name, ("console_form",)):
        op.execute(statement)


def downgrade() -> None:
    for statement in append_only.drop_statements(op.get_bind().dialect.name, ("console_form",)):
        if "FUNCTION" not in statement:  # shared by every other append-only table
            op.execute(statement)
    op.drop_table("console_form")
