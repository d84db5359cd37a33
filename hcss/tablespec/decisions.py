"""The decisions table: written by the simulation-only experiment and by the study export alike.

A study's decisions are stored as they happen (`DecisionRow.record`) without
the columns that say who and where (`EXPORT_IDENTITY`), which the export
adds: :func:`stored_decision` is the record as stored, checked against this
contract, and :func:`exported_decision` reads a stored record back as a row
of the table.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hcss.tablespec.spec import Column, TableSpec, check_row

DECISIONS = TableSpec(
    name="decisions",
    title="decisions",
    description="""
One row per completed (or timed-out) collective decision. The simulation-only
experiment (`hcss simulate experiment`) and the study export write this table
with **identical columns**; `source` tells them apart, so the analysis treats
both alike. Decisions still under way when a section or a trial ends are
discarded, as the study does, and do not appear.
""".strip(),
    columns=(
        Column(
            "source",
            "str",
            "`simulation` (no human in the loop), `study` (a human-collective team) or "
            "`synthetic` (a synthetic operator's team, `hcss plan`)",
            nullable=False,
            required=True,
        ),
        Column(
            "model",
            "str",
            "`M1` original honeybee model, `M2` bias-reducing, `M3` human-driven",
            nullable=False,
            required=True,
        ),
        Column("participant", "str", "participant code; empty for `simulation`", required=True),
        Column(
            "trial_id",
            "str",
            "unique id of the trial or simulation run",
            nullable=False,
            required=True,
        ),
        Column(
            "scenario_id",
            "str",
            "id of the scenario (target layout and seed) that the trial used",
            nullable=False,
            required=True,
        ),
        Column(
            "run",
            "int",
            "replicate number of the scenario for `simulation` (0-based); 0 for `study`",
            nullable=False,
            required=True,
        ),
        Column("seed", "int", "the trial's random seed", nullable=False),
        Column(
            "first_section",
            "str",
            "`easy` or `difficult`: which section the trial started with",
            nullable=False,
        ),
        Column(
            "section",
            "int",
            "1 or 2: the section of the trial the decision belongs to",
            nullable=False,
        ),
        Column(
            "section_kind",
            "str",
            "`easy` or `difficult`: the kind of that section's initial target layout",
            nullable=False,
        ),
        Column("collective", "str", "`I`, `II`, `III` or `IV`", nullable=False, required=True),
        Column(
            "decision_index",
            "int",
            "1-based index of the decision within its collective's trial",
            nullable=False,
            required=True,
        ),
        Column(
            "difficulty",
            "str",
            "`easy` or `difficult`, fixed at the decision's start (simulation spec §2)",
            nullable=False,
            required=True,
        ),
        Column(
            "start_s",
            "float",
            "simulation time of the decision's start, from the trial's start",
            nullable=False,
        ),
        Column(
            "end_s",
            "float",
            "simulation time of the relocation that ended it (or of the time-out)",
            nullable=False,
        ),
        Column("decision_time_s", "float", "`end_s - start_s`", required=True),
        Column(
            "timed_out",
            "bool",
            "the decision had not ended after the 30-minute cap (simulation only)",
            nullable=False,
            required=True,
        ),
        Column("chosen_target", "int", "id of the chosen target; empty when timed out"),
        Column("chosen_value", "float", "true value of the chosen target; empty when timed out"),
        Column(
            "chosen_distance_m",
            "float",
            "distance from the hub to the chosen target, at the decision's start",
        ),
        Column(
            "best_target",
            "int",
            "id of the highest-valued target in range and not reserved, when the move began",
        ),
        Column("best_value", "float", "its true value"),
        Column(
            "correct",
            "bool",
            "`chosen_value == best_value`; `false` when timed out",
            nullable=False,
            required=True,
        ),
        Column(
            "n_requests",
            "int",
            "accepted operator requests for this collective during the decision",
            nullable=False,
            required=True,
        ),
        Column(
            "n_investigate", "int", "accepted investigate requests", nullable=False, required=True
        ),
        Column("n_abandon", "int", "accepted abandon requests", nullable=False, required=True),
        Column("n_decide", "int", "accepted decide requests", nullable=False, required=True),
        Column(
            "n_interventions",
            "int",
            "abandons issued while at least 10% of the collective favoured the target",
            nullable=False,
            required=True,
        ),
    ),
)


#: The columns the study export adds to a stored decision: who and where.
EXPORT_IDENTITY = ("source", "participant", "trial_id", "run")
#: The columns of a stored decision record (`DecisionRow.record`), in the table's order.
RECORD_COLUMNS: tuple[str, ...] = tuple(
    name for name in DECISIONS.names if name not in EXPORT_IDENTITY
)


def stored_decision(row: Mapping[str, Any]) -> dict[str, Any]:
    """A decisions row as a study stores it: RECORD_COLUMNS in order, the export's own left out.

    RowError unless the row keeps the contract: a column the table does not
    name or a missing record column is refused, as is a value of another
    type or an empty cell where the dictionary allows none. The identity
    columns (`DecisionRecord.as_row()` fills them) are dropped unchecked.
    """
    record = {name: value for name, value in row.items() if name not in EXPORT_IDENTITY}
    check_row(DECISIONS, record, RECORD_COLUMNS)
    return {name: record[name] for name in RECORD_COLUMNS}


def exported_decision(record: Mapping[str, Any], participant: str, trial_id: str) -> dict[str, Any]:
    """A stored record as a row of the decisions table, who and where added by the export.

    Read through the contract: the table's columns in order, a column the
    record lacks empty. Records stored by earlier versions are read alike;
    those may also carry source, participant, trial_id and run, which the
    export's own replace, and columns since dropped, which are left out.
    """
    row = {name: record.get(name) for name in DECISIONS.names}
    row.update(source="study", participant=participant, trial_id=trial_id, run=0)
    return row
