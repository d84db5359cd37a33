"""The analysis's own tables: what `hcss analyze`, a sweep's analysis and the experiment's summary write.

`hcss analyze OUT` writes `measures.csv`, the R script's inputs
(`model_decisions.csv`, `mrt_scores.csv`) and one `tables/<name>.csv` per
table of the report; `hcss simulate experiment` writes `summary.csv` and the
`paper_units_*` tables beside its decisions; the analysis of a sweep writes
`tables/sweep_cells.csv`. Each is checked against its spec here when it is
written (`hcss.analysis.tables.write_checked`): a column the spec does not
name, a column it needs that is missing, or a cell of the wrong type stops
the write with the table, column and row named.

Some names stand for a family of tables, one per measure or measure family
(`descriptive_<measure>`, `family_<family>`, `pmatrix_<family>`):
:func:`analysis_table` finds the spec of a written name. Where a table's
columns depend on its inputs (the counterbalancing table's column per
status, a sweep's column per parameter), the spec names the fixed columns
and one pattern column for the rest.
"""

from __future__ import annotations

import re
from functools import cache

from hcss.tablespec.export import SCORES
from hcss.tablespec.spec import Column, TableSpec


def _measure(description: str = "measure key, e.g. `success_rate` or `nasa_tlx.overall`") -> Column:
    return Column("measure", "str", description, nullable=False)


_SPLIT = Column(
    "split",
    "str",
    "`overall`, `easy` or `difficult`: the decisions the measure is computed over",
    nullable=False,
)
_GROUP = Column(
    "group",
    "str",
    "the model group: `M1SIM`, `M2SIM` (simulation-only), `M1`–`M3` (study) or `All`",
    nullable=False,
)
_P = Column("p", "float", "p value; empty when the test could not run")
_METHOD = Column("method", "str", "the test's variant as run (exact, asymptotic, ...)")
_NOTE = Column("note", "str", "why a test did not run or what was left out; empty when nothing")
_INTERVAL_METHOD = Column(
    "interval_method", "str", "how the effect size's 95% interval was computed, or why none"
)
_FAMILY = Column(
    "family", "str", "the comparison family the test belongs to (Holm within a family)"
)
_GROUP_A = Column("group_a", "str", "the first model of the pair", nullable=False)
_GROUP_B = Column("group_b", "str", "the second model of the pair", nullable=False)


def _summary(n: str, nullable_n: bool = False) -> tuple[Column, ...]:
    """n, mean, SD, median, minimum and maximum of a measure's values."""
    return (
        Column("n", "int", n, nullable=nullable_n),
        Column("mean", "float", "mean"),
        Column("sd", "float", "sample SD (n − 1); empty for a single value"),
        Column("median", "float", "median"),
        Column("minimum", "float", "smallest value"),
        Column("maximum", "float", "largest value"),
    )


def _effect(name: str, meaning: str) -> tuple[Column, ...]:
    """An effect size with its 95% interval and how the interval was computed."""
    return (
        Column(name, "float", meaning),
        Column(f"{name}_lower", "float", "lower end of its 95% interval"),
        Column(f"{name}_upper", "float", "upper end of its 95% interval"),
        _INTERVAL_METHOD,
    )


MEASURES = TableSpec(
    name="measures",
    title="Measures (`hcss analyze`: OUT/measures.csv)",
    description="""
Every measure of every analysis unit, long: one row per measure, split, group
and unit. The unit is a participant (study) or a scenario with its runs
averaged (simulation-only); the measures are those of docs/analysis.md.
""".strip(),
    columns=(
        _measure(),
        _SPLIT,
        _GROUP,
        Column("source", "str", "`simulation` or `study`", nullable=False),
        Column(
            "unit",
            "str",
            "the analysis unit: participant code, or scenario id for the simulation",
            nullable=False,
        ),
        Column("participant", "str", "participant code; empty for the simulation"),
        Column("value", "float", "the unit's value; empty when it has none in that split"),
    ),
)

MODEL_DECISIONS = TableSpec(
    name="model_decisions",
    title="Model decisions (`hcss analyze`: OUT/model_decisions.csv, read by analysis.R)",
    description="""
The study's human decisions the repeated-measures models were fitted to, with
the order covariates they used; analysis.R refits the models from it. Written
only when the inputs hold study decisions.
""".strip(),
    columns=(
        Column("participant", "str", "participant code", nullable=False),
        Column("trial_id", "str", "the trial", nullable=False),
        Column("model", "str", "`M1`, `M2` or `M3`", nullable=False),
        Column("difficulty", "str", "`easy` or `difficult`", nullable=False),
        Column("correct", "int", "1 when the decision was correct, else 0 (for R)", nullable=False),
        Column("decision_time_s", "float", "the decision's time"),
        Column("position", "int", "the trial's position in the participant's order, 1–3"),
        Column("first_section", "str", "`easy` or `difficult`: the trial's first section"),
    ),
)

MRT_SCORES = TableSpec(
    name="mrt_scores",
    title="MRT scores (`hcss analyze`: OUT/mrt_scores.csv, read by analysis.R)",
    description="""
The export's own Mental Rotations Test rows (total and parts, as scored), so
that analysis.R recomputes the MRT measure from the export, not from hcss.
""".strip(),
    columns=(
        Column("participant", "str", "participant code", nullable=False),
        Column(
            "scale",
            "str",
            "`total`, `part_1` or `part_2` (the export's rows), or `stored` (participants table)",
            nullable=False,
        ),
        SCORES.column("score"),
    ),
)

SWEEP_CELLS = TableSpec(
    name="sweep_cells",
    title="Sweep cells (`hcss analyze SWEEP`: OUT/tables/sweep_cells.csv)",
    description="""
One row per cell of a sweep and model. Success rates are the mean over trials
of each trial's share of correct decisions.
""".strip(),
    columns=(
        Column(
            "<parameter>",
            "any",
            "one column per swept parameter, named after it: the cell's value",
            nullable=False,
            pattern=True,
        ),
        Column("model", "str", "the model", nullable=False),
        Column("trials", "int", "trials of the cell and model", nullable=False),
        Column("decisions", "int", "their decisions", nullable=False),
        Column("success_overall", "float", "success rate over all decisions (0–1)"),
        Column("success_easy", "float", "over the easy decisions; empty without any"),
        Column("success_difficult", "float", "over the difficult decisions; empty without any"),
        Column("decision_time_min", "float", "mean decision time in minutes", nullable=False),
    ),
)

SAMPLE = TableSpec(
    name="sample",
    title="Report table `sample`",
    description="Participants by status, and the bots, pilots and demos left out or kept.",
    columns=(
        Column("row", "str", "what is counted, as the report labels it", nullable=False),
        Column("n", "int", "how many", nullable=False),
    ),
)

ATTRITION = TableSpec(
    name="attrition",
    title="Report table `attrition`",
    description=(
        "Per stage in protocol order: analysed participants who entered it, submitted it, "
        "were moved past it by the experimenter, or entered and left it unsubmitted."
    ),
    columns=(
        Column("stage", "str", "the stage", nullable=False),
        Column("entered", "int", "participants who entered it", nullable=False),
        Column("submitted", "int", "participants who submitted it (not skipped)", nullable=False),
        Column(
            "skipped",
            "int",
            "participants the experimenter moved past it (`stage_timings.skipped`), entered or not",
            nullable=False,
        ),
        Column(
            "lost",
            "int",
            "participants who entered it and neither submitted it nor were moved past it",
            nullable=False,
        ),
    ),
)

DEMOGRAPHICS = TableSpec(
    name="demographics",
    title="Report table `demographics`",
    description="Counts per answer of each categorical item; mean and SD of each numeric one.",
    columns=(
        Column("item", "str", "the demographics item", nullable=False),
        Column("value", "str", "the answer (`not answered` when none), or `mean`", nullable=False),
        Column("n", "int", "participants with that answer (with a numeric answer)", nullable=False),
        Column("mean", "float", "mean of a numeric item; empty for an answer count"),
        Column("sd", "float", "its sample SD"),
    ),
)

COUNTERBALANCING = TableSpec(
    name="counterbalancing",
    title="Report table `counterbalancing`",
    description="""
Analysed participants per counterbalancing cell and model order, with one
column per status met in the inputs (so the columns after `model_order`
depend on the sample).
""".strip(),
    columns=(
        Column("cell", "str", "counterbalancing cell", nullable=False),
        Column("model_order", "str", "models in the order met; `–` when unknown", nullable=False),
        Column(
            "<status>",
            "int",
            "one column per participant status (`completed`, `aborted`, ...): the count",
            nullable=False,
            pattern=True,
        ),
    ),
)

DESCRIPTIVE = TableSpec(
    name="descriptive_<measure>",
    title="Report tables `descriptive_<measure>` (one per measure)",
    description="The measure's descriptive statistics per model and split, over analysis units.",
    columns=(_measure(), _GROUP, _SPLIT, *_summary("units with a value")),
)

FAMILY = TableSpec(
    name="family_<family>",
    title="Report tables `family_<family>` (one per measure family)",
    description="A family's measures per model and split, with the omnibus p of both designs.",
    columns=(
        _measure(),
        _SPLIT,
        _GROUP,
        *_summary("units with a value")[:4],
        Column("kruskal_p", "float", "Kruskal-Wallis p across models (independent groups)"),
        Column("friedman_p", "float", "Friedman p across M1–M3 (repeated measures)"),
    ),
)

PMATRIX = TableSpec(
    name="pmatrix_<family>",
    title="Report tables `pmatrix_<family>` (one per measure family)",
    description="""
Pairwise p of M1–M3 per measure and split: above the diagonal Tukey-Kramer
on mean ranks, below paired Wilcoxon with Holm.
""".strip(),
    columns=(
        _measure(),
        _SPLIT,
        Column("row", "str", "the model of the matrix row", nullable=False),
        Column("column", "str", "the model of the matrix column", nullable=False),
        Column(
            "test",
            "str",
            "`tukey_kramer_ranks` or `wilcoxon_holm`: where p comes from",
            nullable=False,
        ),
        Column(
            "p", "float", "the pair's p (Holm-adjusted below the diagonal); empty when untested"
        ),
    ),
)

KRUSKAL_WALLIS = TableSpec(
    name="kruskal_wallis",
    title="Report table `kruskal_wallis`",
    description="Kruskal-Wallis tests across models, per measure, split and family.",
    columns=(
        _measure(),
        _SPLIT,
        _FAMILY,
        Column("groups", "str", "the models compared, comma-separated", nullable=False),
        Column("H", "float", "the statistic H"),
        Column("df", "float", "its degrees of freedom"),
        Column("n", "int", "units compared"),
        _P,
        *_effect("epsilon_squared", "ε² = H/(n − 1)"),
        _METHOD,
        _NOTE,
    ),
)


def _posthoc(name: str, title: str, statistic: str, meaning: str) -> TableSpec:
    return TableSpec(
        name=name,
        title=f"Report table `{name}`",
        description=f"{title}: every pair of every Kruskal-Wallis family.",
        columns=(
            _measure(),
            _SPLIT,
            _FAMILY,
            _GROUP_A,
            _GROUP_B,
            Column("difference", "float", "difference of the pair (`group_a - group_b`)"),
            Column("lower", "float", "lower end of its 95% interval"),
            Column("upper", "float", "upper end of its 95% interval"),
            Column(statistic, "float", meaning),
            _P,
        ),
    )


TUKEY_KRAMER_RANKS = _posthoc(
    "tukey_kramer_ranks",
    "Tukey-Kramer comparisons of Kruskal-Wallis mean ranks",
    "q",
    "studentized range statistic",
)
DUNN_HOLM = _posthoc("dunn_holm", "Dunn's test with Holm correction", "z", "Dunn's z")
TUKEY_HSD = _posthoc("tukey_hsd", "Tukey HSD on raw values", "q", "studentized range statistic")

FRIEDMAN = TableSpec(
    name="friedman",
    title="Report table `friedman`",
    description="Friedman tests across M1–M3 of the participants with all three.",
    columns=(
        _measure(),
        _SPLIT,
        Column("n", "int", "participants with all three models", nullable=False),
        Column("chi2", "float", "Friedman's χ²"),
        Column("df", "float", "its degrees of freedom"),
        _P,
        *_effect("kendall_w", "Kendall's W"),
        _METHOD,
        _NOTE,
    ),
)

WILCOXON_PAIRED = TableSpec(
    name="wilcoxon_paired",
    title="Report table `wilcoxon_paired`",
    description="Paired Wilcoxon signed-rank tests per pair of models, Holm within measure and split.",
    columns=(
        _measure(),
        _SPLIT,
        _GROUP_A,
        _GROUP_B,
        Column("n", "int", "participants with both models", nullable=False),
        Column("V", "float", "the signed-rank statistic as R prints it"),
        _P,
        Column("p_holm", "float", "p adjusted by Holm within measure and split"),
        *_effect("rank_biserial_r", "matched-pairs rank-biserial r"),
        _METHOD,
        _NOTE,
    ),
)

MANN_WHITNEY = TableSpec(
    name="mann_whitney",
    title="Report table `mann_whitney`",
    description="Mann-Whitney-Wilcoxon tests of the two simulation-only models.",
    columns=(
        _measure(),
        _SPLIT,
        _GROUP_A,
        _GROUP_B,
        Column("n_a", "int", "units of `group_a`", nullable=False),
        Column("n_b", "int", "units of `group_b`", nullable=False),
        Column("U", "float", "U = min(U₁, U₂), the paper's statistic"),
        Column("W", "float", "W = U₁, as R's `wilcox.test` prints it"),
        _P,
        *_effect("rank_biserial_r", "rank-biserial r"),
        _METHOD,
        _NOTE,
    ),
)


def _spearman(name: str, description: str) -> TableSpec:
    return TableSpec(
        name=name,
        title=f"Report table `{name}`",
        description=description,
        columns=(
            Column("x", "str", "the measure correlated", nullable=False),
            Column("y", "str", "the measure it is correlated with", nullable=False),
            _GROUP,
            Column("rho", "float", "Spearman's ρ"),
            Column("rho_lower", "float", "lower end of its 95% interval (Fisher z)"),
            Column("rho_upper", "float", "upper end of its 95% interval"),
            Column("df", "float", "degrees of freedom"),
            _P,
            Column("n", "int", "units correlated"),
            _METHOD,
            _NOTE,
        ),
    )


SPEARMAN = _spearman("spearman", "Spearman correlations of the measures with success rate.")
SPEARMAN_MRT = _spearman("spearman_mrt", "Spearman correlations of MRT score with success rate.")


def _model(name: str, ratio: str, title: str) -> TableSpec:
    return TableSpec(
        name=name,
        title=f"Report table `{name}`",
        description=f"""
{title} by model × difficulty (and order covariates): one row per term, then
one per variance component; a model that was not fitted is one row `not
fitted` with the reason in `note`.
""".strip(),
        columns=(
            Column(
                "term", "str", "the term (vs M1, easy), or `variance: <component>`", nullable=False
            ),
            Column(ratio, "float", f"the term's {ratio.replace('_', ' ')}, exp(β)"),
            Column("lower", "float", "lower end of its 95% interval"),
            Column("upper", "float", "upper end of its 95% interval"),
            _P,
            Column("p_method", "str", "how p was computed"),
            _NOTE,
            Column("variance", "float", "a variance component's estimate"),
            Column("robust_lower", "float", "CR2 cluster-robust 95% interval, lower (mixed model)"),
            Column("robust_upper", "float", "CR2 cluster-robust 95% interval, upper"),
            Column("robust_p", "float", "p from CR2 errors on Satterthwaite df (Bell–McCaffrey)"),
            Column("robust_df", "float", "the Satterthwaite df of the CR2 test"),
            Column(
                "detectable_ratio",
                "float",
                "the smallest ratio (> 1) the CR2 test detects with 80% power at α = .05",
            ),
        ),
    )


GEE_SUCCESS = _model("gee_success", "odds_ratio", "Success (GEE, logit)")
MIXEDLM_TIME = _model("mixedlm_time", "time_ratio", "Log decision time (linear mixed model)")


def _paper_units(name: str, what: str) -> TableSpec:
    return TableSpec(
        name=name,
        title=f"Report table `{name}`",
        description=f"""
The simulation-only experiment's {what} under the study's unit, beside the
study's published numbers.
""".strip(),
        columns=(
            Column("model", "str", "the simulation-only model (`M1`, `M2`)", nullable=False),
            Column(
                "source", "str", "`this run`, or `study` for the published numbers", nullable=False
            ),
            _SPLIT,
            _measure("`success_pct` or `time_min`"),
            *_summary("units of this run; empty for the study's row", nullable_n=True),
        ),
    )


_UNIT_MEASURE = _measure("`success_pct` or `time_min`")
STUDY_UNITS_MANN_WHITNEY = TableSpec(
    name="study_units_mann_whitney",
    title="Report table `study_units_mann_whitney`",
    description="""
The study's Mann-Whitney tests of the simulation-only models (M2 vs M1) over
its own units (`paper_units_*`), as the study prints them; the units are not
independent.
""".strip(),
    columns=(
        _UNIT_MEASURE,
        _SPLIT,
        Column("n_m1", "int", "units of M1", nullable=False),
        Column("n_m2", "int", "units of M2", nullable=False),
        Column("N", "int", "n₁ + n₂, as the study prints it", nullable=False),
        Column("dof", "int", "groups − 1, as the study prints it", nullable=False),
        Column("U", "float", "U = min(U₁, U₂), the paper's statistic"),
        Column("W", "float", "W of M2 over M1, as R's `wilcox.test(m2, m1)` prints it"),
        _P,
        *_effect("rank_biserial_r", "rank-biserial r (positive: M2 larger)"),
        Column("shift", "float", "Hodges–Lehmann shift M2 − M1 (points or minutes)"),
        Column("shift_lower", "float", "lower end of its 95% interval (R's wilcox.test)"),
        Column("shift_upper", "float", "upper end of its 95% interval"),
        Column("shift_method", "str", "how the interval was found"),
        _METHOD,
    ),
)
STUDY_UNITS_SPEARMAN = TableSpec(
    name="study_units_spearman",
    title="Report table `study_units_spearman`",
    description="Spearman ρ of decision time with success over the study's units, per model and split.",
    columns=(
        _GROUP,
        _SPLIT,
        Column("n", "int", "units", nullable=False),
        Column("rho", "float", "Spearman's ρ"),
        Column("rho_lower", "float", "lower end of its 95% interval (Fisher z)"),
        Column("rho_upper", "float", "upper end of its 95% interval"),
        _P,
        _METHOD,
        _NOTE,
    ),
)
STUDY_FIVE_GROUPS_KRUSKAL = TableSpec(
    name="study_five_groups_kruskal",
    title="Report table `study_five_groups_kruskal`",
    description="""
The study's Kruskal-Wallis over M1 SIM, M2 SIM (its units) and M1–M3 (single
human decisions), when the inputs hold both.
""".strip(),
    columns=(
        _UNIT_MEASURE,
        _SPLIT,
        Column("groups", "str", "the groups tested, space-separated", nullable=False),
        Column("n", "int", "values in all groups", nullable=False),
        Column("df", "float", "groups − 1"),
        Column("chi2", "float", "Kruskal-Wallis χ² (tie-corrected)"),
        _P,
        _METHOD,
        _NOTE,
    ),
)
STUDY_FIVE_GROUPS_TUKEY_KRAMER = _posthoc(
    "study_five_groups_tukey_kramer",
    "Tukey-Kramer comparisons of the five groups' mean ranks",
    "q",
    "studentized range statistic",
)

PAPER_UNITS_SUCCESS = _paper_units("paper_units_success", "success rate (%)")
PAPER_UNITS_TIME = _paper_units("paper_units_time", "decision time (minutes)")

SUMMARY = TableSpec(
    name="summary",
    title="Report table `summary` (`hcss simulate experiment`: OUT/summary.csv)",
    description="The simulation-only experiment per model and split, over scenarios (runs averaged).",
    columns=(
        Column("model", "str", "`M1` or `M2`", nullable=False),
        _SPLIT,
        _measure("`success_rate` or `decision_time_min`"),
        *_summary("scenarios"),
    ),
)

NO_ROWS = TableSpec(
    name="no_rows",
    title="A table with no rows",
    description="""
A table that has nothing to show (a design the sample does not allow, say) is
written with this one column instead of an empty file.
""".strip(),
    columns=(Column("note", "str", "`no rows: ` and the table's caption", nullable=False),),
)

#: The tables of the report and of the experiment's summary, as `write_paper_table` writes them.
REPORT_TABLES: tuple[TableSpec, ...] = (
    SAMPLE,
    ATTRITION,
    DEMOGRAPHICS,
    COUNTERBALANCING,
    DESCRIPTIVE,
    FAMILY,
    PMATRIX,
    KRUSKAL_WALLIS,
    TUKEY_KRAMER_RANKS,
    DUNN_HOLM,
    TUKEY_HSD,
    FRIEDMAN,
    WILCOXON_PAIRED,
    MANN_WHITNEY,
    SPEARMAN,
    SPEARMAN_MRT,
    GEE_SUCCESS,
    MIXEDLM_TIME,
    PAPER_UNITS_SUCCESS,
    PAPER_UNITS_TIME,
    STUDY_UNITS_MANN_WHITNEY,
    STUDY_UNITS_SPEARMAN,
    STUDY_FIVE_GROUPS_KRUSKAL,
    STUDY_FIVE_GROUPS_TUKEY_KRAMER,
    SUMMARY,
)

#: Every table the analysis writes, in the dictionary's order.
ANALYSIS_TABLES: tuple[TableSpec, ...] = (
    MEASURES,
    MODEL_DECISIONS,
    MRT_SCORES,
    *REPORT_TABLES,
    SWEEP_CELLS,
    NO_ROWS,
)


@cache
def _named(pattern: str) -> re.Pattern[str]:
    """A spec's name as a pattern: `<measure>` stands for one file-name word or more."""
    parts = re.split(r"(<[a-z_]+>)", pattern)
    return re.compile(
        "".join("[a-z0-9_]+" if part.startswith("<") else re.escape(part) for part in parts)
    )


def analysis_table(name: str) -> TableSpec:
    """The spec of the report table written as `name` (`descriptive_success_rate`, say).

    A name no spec covers is a LookupError: every table the analysis writes has a contract.
    """
    for spec in REPORT_TABLES:
        if spec.name == name:
            return spec
    for spec in REPORT_TABLES:
        if "<" in spec.name and _named(spec.name).fullmatch(name):
            return spec
    raise LookupError(
        f"the analysis writes a table {name!r} that no spec in hcss.tablespec.analysis describes"
    )
