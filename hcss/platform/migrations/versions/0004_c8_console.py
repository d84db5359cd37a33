"""Console: the study chosen for a participant, and the presence table of heartbeats.

`participant.study` is the study file the experimenter picked when creating
the participant (NULL: the server's default). `participant_presence` is
operational state (one row per participant, overwritten by each heartbeat of
the participant's page), not participant data; see
hcss/platform/models/presence.py.

Revision ID: 0004_c8_console
Revises: 0003_study
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004_c8_console"
down_revision = "0003_study"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.add_column(sa.Column("study", sa.String(length=64), nullable=True))
    op.create_table(
        "participant_presence",
        sa.Column("participant_id", sa.Integer(), nullable=False),
        sa.Column("last_seen_epoch", sa.Double(), nullable=False),
        sa.Column("page", sa.String(length=16), nullable=False),
        sa.Column("hidden", sa.Boolean(), nullable=False),
        sa.ForeignKeyConstraint(
            ["participant_id"],
            ["participant.id"],
            name=op.f("fk_participant_presence_participant_id_participant"),
        ),
        sa.PrimaryKeyConstraint("participant_id", name=op.f("pk_participant_presence")),
    )


def downgrade() -> None:
    op.drop_table("participant_presence")
    with op.batch_alter_table("participant", schema=None) as batch_op:
        batch_op.drop_column("study")
