"""The group's members (`group_member`, for placement), and snapshots that may be pruned.

Written by hand to match `GroupMember` in hcss/platform/models/lease.py (not
append-only: a heartbeat updates it). The `snapshot` table's DELETE trigger is
made again with its one exception (hcss.platform.models.append_only.SUPERSEDED):
a snapshot may be deleted once a newer snapshot of the same trial exists. Its
UPDATE stays refused, and every other table keeps its triggers as they were.

Revision ID: i41p_placement_snapshots
Revises: i29_lease_wanted
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

revision = "i41p_placement_snapshots"
down_revision = "i29_lease_wanted"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "group_member",
        sa.Column("address", sa.String(length=128), nullable=False),
        sa.Column("process", sa.String(length=128), nullable=False),
        sa.Column("started_epoch", sa.Double(), nullable=False),
        sa.Column("seen_epoch", sa.Double(), nullable=False),
        sa.PrimaryKeyConstraint("address", name=op.f("pk_group_member")),
    )
    _snapshot_triggers()


def downgrade() -> None:
    op.drop_table("group_member")
    _snapshot_triggers(superseded=False)


def _snapshot_triggers(*, superseded: bool = True) -> None:
    dialect = op.get_bind().dialect.name
    for statement in append_only.drop_statements(dialect, ("snapshot",)):
        if "hcss_append_only()" in statement and "FUNCTION" in statement:
            continue  # shared by every other append-only table
        op.execute(statement)
    if superseded:
        statements = append_only.trigger_statements(dialect, ("snapshot",))
    else:
        kept = append_only.SUPERSEDED.pop("snapshot")
        try:
            statements = append_only.trigger_statements(dialect, ("snapshot",))
        finally:
            append_only.SUPERSEDED["snapshot"] = kept
    for statement in statements:
        op.execute(statement)
