"""Hardening (issue 13): trial problems; outages on interruption rows; append-only triggers.

`trial_problem` holds what a rebuild could not use: a stored command whose
refusal cannot be shown, or a whole trial that could not be loaded (which is
then ended with reason ``rebuild_failed``). Written by hand against
hcss/platform/models/trial.py; the app only ever inserts into it.
`interruption.outage_s` is the wall time the trial clock stood still while
the server was down (hcss/platform/live/outages.py); 0 for older rows.
`experimenter.login_generation` moves on at each sign-out, ending the
account's cookies server-side (hcss/platform/console/login_sessions.py).
Triggers refuse UPDATE and DELETE on the append-only tables; a DELETE passes
only inside a withdrawal's transaction, which holds a `deletion_permit` row
(hcss/platform/models/append_only.py, whose DDL this revision runs).

Revision ID: 0004_h13_hardening
Revises: 0004_p8_idempotency
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

#: The tables this revision makes append-only (fixed here; later revisions add their own).
APPEND_ONLY_TABLES = (
    "audit_record",
    "participant",
    "consent_record",
    "questionnaire_item",
    "score",
    "stage_event",
    "study_enrolment",
    "trial",
    "command",
    "console_action",
    "decision",
    "interruption",
    "observation",
    "probe",
    "request_status_change",
    "sim_event",
    "snapshot",
    "trial_problem",
    "trial_status_change",
    "command_outcome",
    "probe_event",
    "recruitment",  # 0004_o14_online: ids written once, at the first visit
    "command_key",  # 0004_p8_idempotency: a command's first answer
)

revision = "0004_h13_hardening"
down_revision = "0004_p8_idempotency"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "trial_problem",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("trial_id", sa.Integer(), nullable=False),
        sa.Column("source", sa.String(length=16), nullable=False),
        sa.Column("record", sa.String(length=64), nullable=False),
        sa.Column("problem", sa.String(length=300), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.ForeignKeyConstraint(
            ["trial_id"], ["trial.id"], name=op.f("fk_trial_problem_trial_id_trial")
        ),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_trial_problem")),
    )
    with op.batch_alter_table("trial_problem", schema=None) as batch_op:
        batch_op.create_index(batch_op.f("ix_trial_problem_trial_id"), ["trial_id"], unique=False)
    op.create_table(
        "deletion_permit",
        sa.Column("id", sa.Integer(), nullable=False),
        sa.Column("reason", sa.String(length=32), nullable=False),
        sa.Column("created_at", sa.DateTime(), nullable=False),
        sa.PrimaryKeyConstraint("id", name=op.f("pk_deletion_permit")),
    )
    with op.batch_alter_table("interruption", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("outage_s", sa.Double(), nullable=False, server_default=sa.text("0"))
        )
    with op.batch_alter_table("experimenter", schema=None) as batch_op:
        batch_op.add_column(
            sa.Column("login_generation", sa.Integer(), nullable=False, server_default=sa.text("0"))
        )
    # After the batch operations: SQLite's batch mode recreates a table, dropping its triggers.
    dialect = op.get_bind().dialect.name
    for statement in append_only.trigger_statements(dialect, APPEND_ONLY_TABLES):
        op.execute(statement)


def downgrade() -> None:
    for statement in append_only.drop_statements(op.get_bind().dialect.name, APPEND_ONLY_TABLES):
        op.execute(statement)
    op.drop_table("deletion_permit")
    with op.batch_alter_table("experimenter", schema=None) as batch_op:
        batch_op.drop_column("login_generation")
    with op.batch_alter_table("interruption", schema=None) as batch_op:
        batch_op.drop_column("outage_s")
    with op.batch_alter_table("trial_problem", schema=None) as batch_op:
        batch_op.drop_index(batch_op.f("ix_trial_problem_trial_id"))
    op.drop_table("trial_problem")
