"""Experimenter console: accounts, session actions (pause, resume, abort, pilot) and the audit.

Written by hand to match hcss/platform/models/console.py. `console_action`
references the participant and the trial, so a withdrawal deletes it with
them; `audit_record` has no foreign key at all, so it outlives the deletion
it records.

Revision ID: 0002_console
Revises: 0001
Create Date: 2026-11-22 03:50:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0002_console"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "experimenter",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("username", sa.String(length=64), nullable=False),
        sa.Column("password_hash", sa.String(length=256), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_experimenter")),
        sa.UniqueConstraint("username", name=op.f("uq_experimenter_username")),
    )
    op.create_table(
        "console_action",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("participant_id", sa.Integer(), nullable=False),
        sa.Column("experimenter_id", sa.Integer(), nullable=True),
        sa.Column("action", sa.String(length=16), nullable=False),
        sa.Column("trial_id", sa.Integer(), nullable=True),
        sa.Column("at_epoch", sa.Double(), nullable=False),
        sa.Column("detail", sa.String(length=200), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["experimenter_id"],
            ["experimenter.id"],
            name=op.f("fk_console_action_experimenter_id_experimenter"),
        ),
        sa.ForeignKeyConstraint(
            ["participant_id"],
            ["participant.id"],
            name=op.f("fk_console_action_participant_id_participant"),
        ),
        sa.ForeignKeyConstraint(
            ["trial_id"], ["trial.id"], name=op.f("fk_console_action_trial_id_trial")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_console_action")),
    )
    with op.batch_alter_table("console_action", schema=None) as batch_op:
        batch_op.create_index(
            batch_op.f("ix_console_action_participant_id"), ["participant_id"], unique=False
        )
        batch_op.create_index(batch_op.f("ix_console_action_trial_id"), ["trial_id"], unique=False)

    op.create_table(
        "audit_record",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("action", sa.String(length=16), nullable=False),
        sa.Column("experimenter", sa.String(length=64), nullable=False),
        sa.Column("participant_code", sa.String(length=32), nullable=True),
        sa.Column("row_counts", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_audit_record")),
    )


def downgrade() -> None:
    op.drop_table("audit_record")
    with op.batch_alter_table("console_action", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_console_action_trial_id"))
        batch_op.drop_index(batch_op.f("ix_console_action_participant_id"))
    op.drop_table("console_action")
    op.drop_table("experimenter")
