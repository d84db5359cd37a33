"""MTurk's turkSubmitTo on the recruitment row: where the debrief posts the worker's assignment.

Written by hand to match `Recruitment.submit_to` in hcss/platform/models/recruitment.py.
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


def downgrade() -> None:
    with op.batch_alter_table("recruitment") as batch:
        batch.drop_column("submit_to")
    # SQLite's batch copies the table, leaving its triggers behind; they are idempotent.
    for statement in append_only.trigger_statements(op.get_bind().dialect.name, ("recruitment",)):
        op.execute(statement)
