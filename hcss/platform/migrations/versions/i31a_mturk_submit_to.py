"""MTurk's turkSubmitTo on the recruitment row (where the debrief posts the worker's assignment),
and `turned_away`: the visitors a full study turned away, for the console's counts.

Written by hand to match `Recruitment.submit_to` and `TurnedAway` in
hcss/platform/models/recruitment.py; `turned_away` is append-only like `screen_out`.
A nullable column added to the append-only table; its triggers forbid updates and
deletes, not new columns, and every existing row keeps NULL (no MTurk study before).

Revision ID: i31a_mturk_submit_to
Revises: 0011_second_factor
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

revision = "i31a_mturk_submit_to"
down_revision = "0011_second_factor"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("recruitment", sa.Column("submit_to", sa.String(length=128), nullable=True))
    op.create_table(
        "turned_away",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("study", sa.String(length=64), nullable=False),
        sa.Column("source", sa.String(length=16), nullable=False),
        sa.Column("recruitment_id", sa.String(length=128), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_turned_away")),
    )
    op.create_index(op.f("ix_turned_away_study"), "turned_away", ["study"])
    for statement in append_only.trigger_statements(op.get_bind().dialect.name, ("turned_away",)):
        op.execute(statement)


def downgrade() -> None:
    for statement in append_only.drop_statements(op.get_bind().dialect.name, ("turned_away",)):
        if "FUNCTION" not in statement:
            op.execute(statement)
    op.drop_index(op.f("ix_turned_away_study"), table_name="turned_away")
    op.drop_table("turned_away")
    with op.batch_alter_table("recruitment") as batch:
        batch.drop_column("submit_to")
    # SQLite's batch copies the table, leaving its triggers behind; they are idempotent.
    for statement in append_only.trigger_statements(op.get_bind().dialect.name, ("recruitment",)):
        op.execute(statement)
