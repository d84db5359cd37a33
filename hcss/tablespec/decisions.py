"""The decisions table: written by the simulation-only experiment and by the study export alike."""

from __future__ import annotations

from hcss.tablespec.spec import Column, TableSpec

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
            "`simulation` (no human in the loop) or `study` (a human-collective team)",
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
