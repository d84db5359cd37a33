"""The report's sections in the paper's order, each with the tables and figures it needs.

Every section is built only from the measures it needs: a missing family
(no decisions, no probes) gives no section, never a failed report. The
tests are computed once here and shared by the tables that show them.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

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
from hcss.analysis.comparisons import correlations, omnibus_comparisons, simulation_comparisons
from hcss.analysis.descriptive import descriptive_frame
from hcss.analysis.design_tables import friedman_table, model_table, paired_wilcoxon_table
from hcss.analysis.families import FAMILIES
from hcss.analysis.figures import comparison_figure, family_figure, profile_figure
from hcss.analysis.load import StudyTables
from hcss.analysis.measures import MRT_MEASURE
from hcss.analysis.paired import repeated_comparisons
from hcss.analysis.paper_tables import family_table, pvalue_matrix
from hcss.analysis.sample import attrition_table, demographics_table, sample_table
from hcss.analysis.stats import MannWhitneyMethod
from hcss.analysis.tables import Table

INDEPENDENT_NOTE = (
    "The paper's tests: Kruskal-Wallis with Tukey-Kramer on mean ranks, Dunn-Holm and Tukey "
    "HSD treat M1, M2 and M3 as independent groups. Each participant meets all three models, "
    "so these tests do not respect the repeated-measures design; their tables say so where "
    "groups share participants."
)
REPEATED_NOTE = (
    "Tests that respect the design: Friedman with Kendall's W and paired Wilcoxon signed-rank "
    "tests (Holm) on participants with all three models; a logistic GEE of success per decision "
    "and a linear mixed model of log decision time, both with the participant as cluster."
)


@dataclass(frozen=True)
class Section:
    """A report section: its anchor, title, explanation, tables and figures to draw."""

    key: str
    title: str
    intro: str = ""
    tables: tuple[Table, ...] = ()
    figures: tuple[tuple[str, Callable[[], Figure]], ...] = field(default=())
    details: tuple[Table, ...] = ()  # written and linked, shown folded (per-scale tables)


def _family_section(family, measures, summary, kruskal, friedman, extra=()) -> Section | None:
    members = family.members(measures)
    if not members:
        return None
    tables = [family_table(family, summary, kruskal, friedman), *extra]
    per_measure = descriptive_tables(summary[summary["measure"].isin(members)])
    details: list[Table] = []
    if family.profile:  # one table for the instrument; per-scale tables folded away
        details = per_measure
    else:
        tables += per_measure
    if family.profile:
        figures = [(family.key, lambda: profile_figure(measures, members, family.title))]
    elif family.key == "performance":
        figures = [(name, lambda name=name: comparison_figure(measures, name)) for name in members]
    else:
        figures = [(family.key, lambda: family_figure(measures, members, family.title))]
    return Section(
        family.key, family.title, "", tuple(t for t in tables if t), tuple(figures), tuple(details)
    )


def _sample_section(tables: StudyTables, include_pilot: bool) -> Section | None:
    if tables.all_participants.empty:
        return None
    return Section(
        "sample",
        "Sample",
        "Counts before exclusions; attrition and demographics of the analysed participants.",
        (
            sample_table(tables.all_participants, include_pilot),
            attrition_table(tables.stage_timings),
            demographics_table(tables.participants),
        ),
    )


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
    sections = [s for s in [_sample_section(tables, include_pilot)] if s]
    covered: set[str] = set()
    for family in FAMILIES:
        extra = []
        if family.key == "mrt":
            mrt = [c for c in correlation_results if c.x == MRT_MEASURE]
            extra = [_renamed(spearman_table(mrt), "spearman_mrt")] if mrt else []
        section = _family_section(family, measures, summary, kruskal, friedman, extra)
        if section:
            sections.append(section)
            covered.update(family.members(measures))
    others = summary[~summary["measure"].isin(covered)]
    if not others.empty:
        sections.append(Section("other", "Other measures", "", tuple(descriptive_tables(others))))
    if omnibus:
        matrices = [
            pvalue_matrix(family, family.members(measures), omnibus, repeated)
            for family in FAMILIES
        ]
        independent = [kruskal_table(omnibus), *[t for t in posthoc_tables(omnibus) if t.rows]]
        independent += [m for m in matrices if m]
        sections.append(
            Section(
                "independent",
                "Model comparisons as in the paper",
                INDEPENDENT_NOTE,
                tuple(independent),
            )
        )
    design = []
    if repeated:
        design += [friedman_table(repeated), paired_wilcoxon_table(repeated)]
    if (tables.decisions["source"] == "study").any():
        design += [
            model_table("gee_success", success_gee(tables.decisions, tables.participants)),
            model_table("mixedlm_time", time_mixed_model(tables.decisions, tables.participants)),
        ]
    if design:
        sections.append(
            Section("repeated", "Repeated-measures analyses", REPEATED_NOTE, tuple(design))
        )
    two_sample = simulation_comparisons(measures, mann_whitney_method, continuity)
    if two_sample:
        sections.append(
            Section("simulation", "Simulation-only models", "", (mann_whitney_table(two_sample),))
        )
    if correlation_results:
        sections.append(
            Section(
                "correlations",
                "Correlations with success rate",
                "",
                (spearman_table(correlation_results),),
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
