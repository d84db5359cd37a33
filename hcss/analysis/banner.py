"""What the sample allows: counts per study, model and cell, and the tests it is too small for.

The report opens with this, so a reader sees the N behind every table before
the tables, and a test the data cannot support is named once, with its
reason, instead of appearing as rows of n = 1. The thresholds are the ones
the tests themselves apply (:data:`~hcss.analysis.comparisons.MIN_UNITS`,
:data:`~hcss.analysis.comparisons.MIN_PAIRS`,
:data:`~hcss.analysis.clustered.MIN_PARTICIPANTS`), so the banner and the tables
cannot disagree.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from hcss.analysis.clustered import MIN_PARTICIPANTS
from hcss.analysis.comparisons import HUMAN_GROUPS, MIN_PAIRS, MIN_UNITS, SIMULATION_PAIR
from hcss.analysis.load import STUDY, StudyTables


@dataclass(frozen=True)
class SampleBanner:
    """Counts to print first, and the tests left out with their reasons."""

    counts: tuple[str, ...]
    not_run: tuple[str, ...]


def _units_per_group(decisions: pd.DataFrame) -> dict[str, int]:
    """Participants (study) or scenarios (simulation) with decisions, per group."""
    units = {}
    for group, rows in decisions.groupby("group"):
        column = "participant" if group in HUMAN_GROUPS else "scenario_id"
        units[str(group)] = int(rows[column].astype(str).nunique())
    return units


def _complete_participants(decisions: pd.DataFrame) -> int:
    """Participants with decisions for every human model: the repeated-measures sample."""
    human = decisions[decisions["group"].isin(HUMAN_GROUPS) & decisions["source"].eq(STUDY)]
    if human.empty:
        return 0
    models = human.groupby("participant")["group"].nunique()
    return int((models == human["group"].nunique()).sum()) if human["group"].nunique() > 1 else 0


def _plural(count: int, word: str) -> str:
    return f"{count} {word}" if count == 1 else f"{count} {word}s"


def _counts(tables: StudyTables, units: dict[str, int], complete: int) -> list[str]:
    lines = []
    people = tables.participants
    if not people.empty and "study" in people.columns:
        per_study = people.groupby(
            people["study"].astype(object).fillna("unknown").astype(str)
        ).size()
        lines.append(
            "Participants analysed per study: "
            + ", ".join(f"{study} {count}" for study, count in per_study.items())
        )
    human = [f"{group} {units[group]}" for group in HUMAN_GROUPS if group in units]
    if human:
        lines.append("Participants with decisions per model: " + ", ".join(human))
        lines.append(f"Participants with every model (repeated-measures sample): {complete}")
    simulation = [f"{group} {units[group]}" for group in SIMULATION_PAIR if group in units]
    if simulation:
        lines.append("Simulation scenarios per model: " + ", ".join(simulation))
    if not people.empty and "cell" in people.columns and people["cell"].notna().any():
        cells = people.groupby(people["cell"].astype("Int64")).size()
        lines.append(
            "Participants per counterbalancing cell: "
            + ", ".join(f"cell {cell}: {count}" for cell, count in cells.items())
        )
    return lines


def _not_run(units: dict[str, int], complete: int, people: int) -> list[str]:
    reasons = []
    human = {group: units[group] for group in HUMAN_GROUPS if group in units}
    sizes = ", ".join(f"{group} {count}" for group, count in human.items())
    if human and sum(count >= MIN_UNITS for count in human.values()) < 2:
        reasons.append(
            "Kruskal-Wallis with Tukey-Kramer, Dunn-Holm and Tukey HSD across M1–M3: "
            f"they need {MIN_UNITS} or more participants in at least two models ({sizes})"
        )
    if human and complete < MIN_UNITS:
        reasons.append(
            "Friedman and paired Wilcoxon tests: "
            f"{_plural(complete, 'participant')} with every model; they need {MIN_UNITS}"
        )
    if human and max(human.values()) < MIN_PAIRS:
        reasons.append(
            f"Spearman correlations per model: they need {MIN_PAIRS} or more participants "
            f"in a model ({sizes})"
        )
    if human and people < MIN_PARTICIPANTS:
        reasons.append(
            f"Decision-level GEE and mixed model: they need {MIN_PARTICIPANTS} or more "
            f"participants ({people}); the GEE's robust errors and the mixed model's "
            "participant variance from fewer participants are not trustworthy"
        )
    simulation = {group: units[group] for group in SIMULATION_PAIR if group in units}
    if len(simulation) == 2 and min(simulation.values()) < MIN_UNITS:
        reasons.append(
            f"Mann-Whitney {' vs '.join(simulation)}: they need {MIN_UNITS} or more scenarios "
            "per model ("
            + ", ".join(f"{group} {count}" for group, count in simulation.items())
            + ")"
        )
    return reasons


def sample_banner(tables: StudyTables) -> SampleBanner:
    """The counts and the left-out tests of the analysed sample."""
    units = _units_per_group(tables.decisions)
    complete = _complete_participants(tables.decisions)
    human = tables.decisions[tables.decisions["group"].isin(HUMAN_GROUPS)]
    people = int(human["participant"].astype(str).nunique())
    return SampleBanner(
        tuple(_counts(tables, units, complete)), tuple(_not_run(units, complete, people))
    )
