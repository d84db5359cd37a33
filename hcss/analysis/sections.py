"""The report's sections in the paper's order, each with the tables and figures it needs.

Every section is built only from the measures it needs: a missing family
(no decisions, no probes) gives no section, never a failed report. The
tests are computed once here and shared by the tables that show them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial

import pandas as pd
from matplotlib.figure import Figure

from hcss.analysis.builders import (
    descriptive_tables,
    kruskal_table,
    mann_whitney_table,
    posthoc_tables,
    spearman_table,
)
from hcss.analysis.clustered import success_gee, time_mixed_model
from hcss.analysis.comparisons import (
    OmnibusComparison,
    correlations,
    omnibus_comparisons,
    simulation_comparisons,
)
from hcss.analysis.descriptive import descriptive_frame
from hcss.analysis.design_tables import friedman_table, model_table, paired_wilcoxon_table
from hcss.analysis.families import FAMILIES, Family
from hcss.analysis.figures import comparison_figure, family_figure, profile_figure
from hcss.analysis.instrument_measures import incomplete_mrt_note, mrt_range_note
from hcss.analysis.load import StudyTables
from hcss.analysis.measures import MRT_MEASURE
from hcss.analysis.paired import RepeatedComparison, repeated_comparisons
from hcss.analysis.paper_tables import family_table, pvalue_matrix
from hcss.analysis.paper_units import paper_unit_tables, simulation_units
from hcss.analysis.sample import (
    attrition_table,
    counterbalancing_table,
    demographics_table,
    sample_table,
)
from hcss.analysis.stats import MannWhitneyMethod
from hcss.analysis.study_tests import five_group_tables, study_tables
from hcss.analysis.tables import Table

INDEPENDENT_NOTE = (
    "The paper's tests: Kruskal-Wallis with Tukey-Kramer on mean ranks, Dunn-Holm and Tukey "
    "HSD treat M1, M2 and M3 as independent groups. Each participant meets all three models, "
    "so these tests do not respect the repeated-measures design; their tables say so where "
    "groups share participants."
)
RANK_REPEATED_NOTE = (
    "Tests that respect the design: Friedman with Kendall's W and paired Wilcoxon signed-rank "
    "tests (Holm) on participants with all three models."
)
MODEL_REPEATED_NOTE = (
    "Decision-level models with the participant as cluster and the counterbalancing (trial "
    "position, first section) as covariates when it varies: a logistic GEE of success "
    "(population-averaged odds ratios; the subject-specific glmer fit is in analysis.R) and a "
    "linear mixed model of log decision time (random intercept; model-based and CR2 "
    "cluster-robust errors side by side)."
)


def repeated_note(rank_tests: bool, models: bool) -> str:
    """The section's introduction, naming only the analyses it shows."""
    return " ".join(
        text
        for text, shown in ((RANK_REPEATED_NOTE, rank_tests), (MODEL_REPEATED_NOTE, models))
        if shown
    )


MULTIPLICITY_NOTE = (
    "Multiplicity: Holm's correction is applied within a family of tests, and only there. "
    "The families are (1) the three pairwise comparisons of one measure and split after "
    "Kruskal-Wallis (Dunn-Holm; Tukey-Kramer and Tukey HSD control the family-wise error "
    "themselves) and (2) the three paired Wilcoxon tests of one measure and split. Omnibus "
    "tests, model terms and correlations across measures are not corrected: read them as "
    "exploratory, one confirmatory hypothesis per pre-registered measure."
)
STUDY_TESTS_NOTE = (
    "The study's tests as it ran them, to set a run beside the paper's printed N, DOF, U and "
    "p: over its simulation units (trial scenario, decision slot; runs averaged) and, for "
    "human-collective teams, over single decisions. Those values are not independent (slots "
    "share a scenario and its runs, decisions share a participant), so these p-values "
    "describe the study's tests; the per-scenario and per-participant tests above are the "
    "report's primary inference."
)
DESIGN_NOTE = (
    "The counterbalancing achieved (participants per cell and model order, by status) and "
    "the attrition by stage of the analysed participants."
)


@dataclass(frozen=True)
class Section:
    """A report section: its anchor, title, explanation, tables and figures to draw."""

    key: str
    title: str
    intro: str = ""
    tables: tuple[Table, ...] = ()
    figures: tuple[tuple[str, Callable[[], Figure]], ...] = field(default=())
    details: tuple[Table, ...] = ()  # written and linked, shown folded
    details_label: str = "Per-measure tables: mean (SD) and median (min–max)"


def _family_section(
    family: Family,
    measures: pd.DataFrame,
    summary: pd.DataFrame,
    kruskal: dict[tuple[str, str], OmnibusComparison],
    friedman: dict[tuple[str, str], RepeatedComparison],
    extra: Sequence[Table] = (),
) -> Section | None:
    members = family.members(measures)
    if not members:
        return None
    tables = [family_table(family, summary, kruskal, friedman), *extra]
    # the family table holds every mean (SD); the per-measure tables (with medians and
    # ranges) repeat them, so they are written and linked but folded away
    details = descriptive_tables(summary[summary["measure"].isin(members)])
    if family.profile:
        figures = [(family.key, lambda: profile_figure(measures, members, family.title))]
    elif family.key == "performance":
        figures = [(name, partial(comparison_figure, measures, name)) for name in members]
    else:
        figures = [(family.key, lambda: family_figure(measures, members, family.title))]
    return Section(
        family.key,
        family.title,
        "",
        tuple(t for t in tables if t and t.rows),
        tuple(figures),
        tuple(t for t in details if t.rows),
    )


def _sample_section(tables: StudyTables, include_pilot: bool) -> Section | None:
    if tables.all_participants.empty:
        return None
    return Section(
        "sample",
        "Sample",
        "Counts before exclusions; demographics of the analysed participants.",
        (
            sample_table(tables.all_participants, include_pilot),
            demographics_table(tables.participants),
        ),
    )


def _design_section(tables: StudyTables) -> Section | None:
    design = [counterbalancing_table(tables.participants), attrition_table(tables.stage_timings)]
    design = [table for table in design if table.rows]
    if not design:
        return None
    return Section("design", "Design achieved", DESIGN_NOTE, tuple(design))


def build_sections(
    tables: StudyTables,
    measures: pd.DataFrame,
    include_pilot: bool = False,
    mann_whitney_method: MannWhitneyMethod = "auto",
    continuity: bool = True,
) -> list[Section]:
    """Every section with content, in the paper's order."""
    summary = descriptive_frame(measures)
    omnibus = omnibus_comparisons(measures)
    repeated = repeated_comparisons(measures)
    kruskal = {(c.measure, c.split): c for c in omnibus if c.family == "human-collective models"}
    friedman = {(c.measure, c.split): c for c in repeated}
    correlation_results = correlations(measures)
    sections = [s for s in [_sample_section(tables, include_pilot), _design_section(tables)] if s]
    covered: set[str] = set()
    for family in FAMILIES:
        extra = []
        if family.key == "mrt":
            mrt = [c for c in correlation_results if c.x == MRT_MEASURE]
            extra = [_renamed(spearman_table(mrt), "spearman_mrt")] if mrt else []
        section = _family_section(family, measures, summary, kruskal, friedman, extra)
        if section and family.key == "mrt":
            notes = (
                mrt_range_note(tables.participants),
                incomplete_mrt_note(tables.scores, tables.participants),
            )
            section = replace(section, intro=" ".join(note for note in notes if note))
        if section:
            sections.append(section)
            covered.update(family.members(measures))
    others = summary[~summary["measure"].isin(covered)]
    if not others.empty:
        sections.append(Section("other", "Other measures", "", tuple(descriptive_tables(others))))
    sections += _test_sections(tables, measures, omnibus, repeated)
    sections += _simulation_sections(measures, tables.decisions, mann_whitney_method, continuity)
    decision_correlations = [c for c in correlation_results if c.x != MRT_MEASURE]
    if decision_correlations:  # the MRT's are in its own section
        sections.append(
            Section(
                "correlations",
                "Correlations with success rate",
                "",
                (spearman_table(decision_correlations),),
            )
        )
    return [section for section in sections if section.tables or section.figures]


def _test_sections(
    tables: StudyTables,
    measures: pd.DataFrame,
    omnibus: list[OmnibusComparison],
    repeated: list[RepeatedComparison],
) -> list[Section]:
    """The paper's independent-groups tests and the repeated-measures analyses."""
    sections = []
    if omnibus:
        matrices = [
            pvalue_matrix(family, family.members(measures), omnibus, repeated)
            for family in FAMILIES
        ]
        independent = [kruskal_table(omnibus), *[m for m in matrices if m]]
        pairwise = [t for t in posthoc_tables(omnibus) if t.rows]
        sections.append(
            Section(
                "independent",
                "Model comparisons as in the paper",
                f"{INDEPENDENT_NOTE} {MULTIPLICITY_NOTE}",
                tuple(table for table in independent if table.rows),
                details=tuple(pairwise),
                details_label="Every pair of every post-hoc test (the matrices above summarise them)",
            )
        )
    ranks: list[Table] = []
    paired: tuple[Table, ...] = ()
    if repeated:
        ranks = [t for t in [friedman_table(repeated)] if t.rows]
        paired = tuple(t for t in [paired_wilcoxon_table(repeated)] if t.rows)
    models = []
    if (tables.decisions["source"] == "study").any():
        for name, model in (
            ("gee_success", success_gee(tables.decisions, tables.participants)),
            ("mixedlm_time", time_mixed_model(tables.decisions, tables.participants)),
        ):
            if model.terms or not model.too_small:  # too small: listed in the banner
                models.append(model_table(name, model))
    design = ranks + [table for table in models if table.rows]
    if design:
        intro = repeated_note(bool(ranks or paired), len(design) > len(ranks))
        sections.append(
            Section(
                "repeated",
                "Repeated-measures analyses",
                f"{intro} {MULTIPLICITY_NOTE}",
                tuple(design),
                details=paired,
                details_label="Paired Wilcoxon tests, every pair (their Holm p is below the "
                "diagonal of the matrices in the previous section)",
            )
        )
    return sections


def _simulation_sections(
    measures: pd.DataFrame,
    decisions: pd.DataFrame,
    mann_whitney_method: MannWhitneyMethod,
    continuity: bool,
) -> list[Section]:
    two_sample = simulation_comparisons(measures, mann_whitney_method, continuity)
    units = simulation_units(decisions)  # computed once for the three uses below
    sections = []
    if two_sample:
        sections.append(
            Section(
                "simulation",
                "Simulation-only models",
                "",
                (mann_whitney_table(two_sample), *paper_unit_tables(decisions, units)),
            )
        )
    own = study_tables(decisions, units)
    five = five_group_tables(decisions, units)
    if own or five:
        sections.append(
            Section(
                "study_tests",
                "The study's own tests, under its units",
                STUDY_TESTS_NOTE,
                (*own, *five[:1]),
                details=tuple(five[1:]),
                details_label="Tukey-Kramer pairs of the five groups",
            )
        )
    return sections


def _renamed(table: Table, name: str) -> Table:
    return Table(
        name,
        table.caption.replace("with success rate", "of MRT score with success rate"),
        table.header,
        table.rows,
        table.frame,
    )
