"""Idempotency keys of the live interface's commands, and probe latencies in ms (issue 8).

Written by hand to match hcss/platform/models/idempotency.py and probe.py. The
unique constraint on (trial_id, key) is what guarantees that a double-clicked
Commit, or a retried POST, is carried out and stored once. `probe_event`
gains `latency_ms`, the wall-clock latency of a ready press or an answer.

Revision ID: 0004_p8_idempotency
Revises: 0004_o14_online
Create Date: 2026-11-26 18:40:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0004_p8_idempotency"
down_revision = "0004_o14_online"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "command_key",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("trial_id", sa.Integer(), nullable=False),
        sa.Column("key", sa.String(length=64), nullable=False),
        sa.Column("endpoint", sa.String(length=64), nullable=False),
        sa.Column("fingerprint", sa.String(length=64), nullable=False),
        sa.Column("status", sa.Integer(), nullable=False),
        sa.Column("response", sa.JSON(), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["trial_id"], ["trial.id"], name=op.f("fk_command_key_trial_id_trial")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_command_key")),
        sa.UniqueConstraint("trial_id", "key", name=op.f("uq_command_key_trial_id_key")),
    )
    with op.batch_alter_table("command_key", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_command_key_trial_id"), ["trial_id"], unique=False)
    with op.batch_alter_table("probe_event", schema=None) as batch_op:
        batch_op.add_column(sa.Column("latency_ms", sa.Double(), nullable=True))


def downgrade() -> None:
    with op.batch_alter_table("probe_event", schema=None) as batch_op:
        batch_op.drop_column("latency_ms")
    with op.batch_alter_table("command_key", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_command_key_trial_id"))
    op.drop_table("command_key")
