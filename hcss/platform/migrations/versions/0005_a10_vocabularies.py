"""Vocabularies enforced (CHECK constraints) and the study's probe counts on each trial (issue 10).

CHECK constraints on trial.kind, trial_status_change.status and
request_status_change.status (hcss.platform.models.vocabularies); a nullable
trial.probe_counts column (the study file's `[probes]`, so a rebuilt trial draws
the same probes).

Revision ID: 0005_a10_vocabularies
Revises: 0004_h13_hardening
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

from hcss.platform.models import append_only

revision = "0005_a10_vocabularies"
down_revision = "0004_h13_hardening"
branch_labels = None
depends_on = None

#: (table, constraint name, column, values): fixed here, as of this revision.
CHECKS = (
    ("trial", "ck_trial_kind", "kind", ("training", "trial")),
    ("trial_status_change", "ck_trial_status_change_status", "status", ("running", "ended")),
    (
        "request_status_change",
        "ck_request_status_change_status",
        "status",
        ("in_progress", "completed", "removed"),
    ),
)
#: SQLite's batch mode recreates these tables, dropping their append-only triggers.
RECREATED = ("trial", "trial_status_change", "request_status_change")


def _condition(column: str, values: tuple[str, ...]) -> str:
    return f"{column} IN ({', '.join(repr(v) for v in values)})"


def upgrade() -> None:
    with op.batch_alter_table("trial", schema=None) as batch_op:
        batch_op.add_column(sa.Column("probe_counts", sa.JSON(), nullable=True))
    for table, name, column, values in CHECKS:
        with op.batch_alter_table(table, schema=None) as batch_op:
            batch_op.create_check_constraint(op.f(name), _condition(column, values))
    dialect = op.get_bind().dialect.name
    for statement in append_only.trigger_statements(dialect, RECREATED):
        op.execute(statement)


def downgrade() -> None:
    for table, name, _column, _values in CHECKS:
        with op.batch_alter_table(table, schema=None) as batch_op:
            batch_op.drop_constraint(op.f(name), type_="check")
    with op.batch_alter_table("trial", schema=None) as batch_op:
        batch_op.drop_column("probe_counts")
    dialect = op.get_bind().dialect.name
    for statement in append_only.trigger_statements(dialect, RECREATED):
        op.execute(statement)
