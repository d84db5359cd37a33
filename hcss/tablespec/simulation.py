"""The simulation's other tables: a sweep's decisions, the equivalence reference, a calibration's trials."""

from __future__ import annotations

from hcss.tablespec.decisions import DECISIONS
from hcss.tablespec.spec import Column, TableSpec

SWEEP_DECISIONS = TableSpec(
    name="decisions",
    title="Sweep decisions (`hcss simulate sweep`: OUT/decisions.csv and OUT/cells/*.csv)",
    description="""
Every cell's decisions, one row per decision: the cell's value of each swept
parameter first, then the columns of `decisions`. A cell's own file
(`cells/<cell>.csv`) has the same columns.
""".strip(),
    columns=(
        Column(
            "<parameter>",
            "any",
            "one column per swept parameter, named after it: the cell's value (a number or "
            "a reading's name)",
            nullable=False,
            pattern=True,
        ),
        *DECISIONS.columns,
    ),
)

EQUIVALENCE_REFERENCE = TableSpec(
    name="reference_outcomes",
    title="Equivalence reference (`python -m hcss.simulation.equivalence write`)",
    description="""
The outcomes of the reduced experiment at pinned parameters, one row per
decision, which a new engine's outcomes are compared with. The columns are
those of `decisions` of the same name.
""".strip(),
    columns=tuple(
        DECISIONS.column(name)
        for name in ("model", "trial_id", "difficulty", "correct", "decision_time_s", "timed_out")
    ),
)

CALIBRATION_TRIALS = TableSpec(
    name="trials",
    title="Calibration trials (`hcss simulate calibrate --to study`: OUT/trials.csv)",
    description="""
One row per completed search trial of the study calibration.
""".strip(),
    columns=(
        Column("trial", "int", "the search trial's number (optuna's)", nullable=False),
        Column(
            "<parameter>",
            "any",
            "one column per searched parameter, named after it: the trial's value (a number "
            "or a reading's name)",
            pattern=True,
        ),
        Column("loss", "float", "the trial's loss against the published numbers"),
        Column(
            "<measure>",
            "any",
            "one column per measure the trial recorded, in name order: `met` (published "
            "numbers met), `m1_easy_success`, `m2_easy_success` (%), `m2_time_cost` "
            "(minutes), and `<model>_<split>_success` (%) and `<model>_<split>_time` "
            "(minutes) per model and split",
            pattern=True,
        ),
    ),
)

SIMULATION_TABLES: tuple[TableSpec, ...] = (
    SWEEP_DECISIONS,
    EQUIVALENCE_REFERENCE,
    CALIBRATION_TRIALS,
)
