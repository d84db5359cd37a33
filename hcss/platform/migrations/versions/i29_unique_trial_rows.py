"""Unique keys on a trial's decisions, events, probes, probe events, request statuses and
interruptions, so a retry or a second writer can never store one twice.

Written by hand to match the unique indexes in hcss/platform/models (`uq_*`).
A database written before this revision may hold such doubles (issue 29: a
commit whose answer was lost, a stalled host that wrote after its lease ran
out). Of each set of rows with one key the first (lowest id) is kept and the
later ones are removed: they say nothing the first does not, and the export
and the analysis would count them twice. Each removed row leaves a
`trial_problem` row (source ``migration``, record ``<table> <id>``, naming the
row it doubled), and the number removed per table is logged as a warning, so
the data say what was done. A probe's events follow the probe that is kept
(the one place a row is changed, with that table's append-only trigger off
for the statement); the removal itself runs under a `deletion_permit`, as the
console's withdrawal does. Rows with no `last_seen_at` are not doubles of one
another (an interruption with nothing seen before it, kept as it is).

Revision ID: i29_unique_trial_rows
Revises: i29_lease_epoch
"""

from __future__ import annotations

import logging
from datetime import UTC, datetime

import sqlalchemy as sa
from alembic import op

revision = "i29_unique_trial_rows"
down_revision = "i29_lease_epoch"
branch_labels = None
depends_on = None

log = logging.getLogger("hcss.migrations")

#: (table, index, key columns); probes before their events, whose key names the probe.
KEYS = (
    ("probe", "uq_probe_trial", ("trial_id", "probe_index")),
    ("probe_event", "uq_probe_event_probe", ("probe_id", "kind")),
    ("decision", "uq_decision_trial", ("trial_id", "collective", "decision_index")),
    ("sim_event", "uq_sim_event_trial", ("trial_id", "kind", "sim_time", "text")),
    (
        "request_status_change",
        "uq_request_status_change_trial",
        ("trial_id", "request_id", "status"),
    ),
    ("interruption", "uq_interruption_trial", ("trial_id", "last_seen_at")),
)


def upgrade() -> None:
    bind = op.get_bind()
    doubles = {table: _doubles(bind, table, columns) for table, _index, columns in KEYS}
    if doubles["probe"]:
        _fold_probe_events(bind, doubles["probe"])
        doubles["probe_event"] = _doubles(bind, "probe_event", ("probe_id", "kind"))
    if any(doubles.values()):
        _remove(bind, doubles)
    for table, index, columns in KEYS:
        op.create_index(index, table, list(columns), unique=True)


def downgrade() -> None:
    for table, index, _columns in reversed(KEYS):
        op.drop_index(index, table_name=table)


def _doubles(bind: sa.Connection, table: str, columns: tuple[str, ...]) -> list[tuple[int, int]]:
    """(id, id of the first row with its key) of every later row with that key."""
    key = ", ".join(columns)
    same = " AND ".join(f"d.{c} = k.{c}" for c in columns)
    return [
        (int(row_id), int(kept))
        for row_id, kept in bind.execute(
            sa.text(
                f"SELECT d.id, k.kept FROM {table} d JOIN (SELECT {key}, MIN(id) AS kept "
                f"FROM {table} GROUP BY {key} HAVING COUNT(*) > 1) k ON {same} "
                "WHERE d.id <> k.kept ORDER BY d.id"
            )
        )
    ]


def _fold_probe_events(bind: sa.Connection, probes: list[tuple[int, int]]) -> None:
    """The events of a probe shown twice move to the probe that is kept (the one UPDATE,
    with probe_event's append-only trigger dropped for it and installed again)."""
    from hcss.platform.models.append_only import trigger_statements

    dialect = bind.dialect.name
    if dialect == "postgresql":
        bind.execute(sa.text("DROP TRIGGER IF EXISTS append_only_probe_event ON probe_event"))
    else:
        bind.execute(sa.text("DROP TRIGGER IF EXISTS append_only_probe_event_update"))
    for removed, kept in probes:
        bind.execute(
            sa.text("UPDATE probe_event SET probe_id = :kept WHERE probe_id = :removed"),
            {"kept": kept, "removed": removed},
        )
    for statement in trigger_statements(dialect, ("probe_event",)):
        bind.execute(sa.text(statement))


def _remove(bind: sa.Connection, doubles: dict[str, list[tuple[int, int]]]) -> None:
    """Delete the doubles under a deletion permit, each leaving a `trial_problem` row."""
    now = datetime.now(UTC).replace(tzinfo=None)  # stored as naive UTC, as the models do
    stamp = sa.bindparam("now", type_=sa.DateTime())
    bind.execute(
        sa.text(
            "INSERT INTO deletion_permit (reason, created_at) VALUES ('migration', :now)"
        ).bindparams(stamp),
        {"now": now},
    )
    for table, _index, columns in reversed(KEYS):  # a probe's events before the probe
        rows = doubles[table]
        if not rows:
            continue
        trial_of = (
            "(SELECT trial_id FROM probe WHERE probe.id = probe_id)"
            if table == "probe_event"
            else "trial_id"
        )
        for row_id, kept in rows:
            bind.execute(
                sa.text(
                    "INSERT INTO trial_problem (trial_id, source, record, problem, created_at) "
                    f"SELECT {trial_of}, 'migration', :record, :problem, :now "
                    f"FROM {table} WHERE id = :id"
                ).bindparams(stamp),
                {
                    "record": f"{table} {row_id}",
                    "problem": (
                        f"a second copy of {table} {kept} (same {', '.join(columns)}); "
                        f"removed by {revision}"
                    ),
                    "now": now,
                    "id": row_id,
                },
            )
        bind.execute(
            sa.text(f"DELETE FROM {table} WHERE id IN ({', '.join(str(i) for i, _ in rows)})")
        )
        log.warning(
            "%s: removed %d %s row(s) that doubled a stored one (the first of each kept; "
            "each removal is a trial_problem row)",
            revision,
            len(rows),
            table,
        )
    bind.execute(sa.text("DELETE FROM deletion_permit WHERE reason = 'migration'"))
