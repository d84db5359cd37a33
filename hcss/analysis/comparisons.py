"""Which tests the study runs on which measures, applied to the tidy measures.

- Human-collective models (M1, M2, M3): Kruskal-Wallis per measure and split,
  then all three post-hoc flavours.
- When simulation-only and human data are both loaded, a second
  Kruskal-Wallis family compares every group (M1SIM … M3) on the measures
  both have (success rate and decision time), as the study's comparison
  figure does.
- Simulation only: Mann-Whitney M1SIM vs M2SIM per measure and split.
- Spearman correlations of success rate with decision time, request
  frequencies and MRT score, per group, and over the human models with one
  value per participant (their mean over M1–M3): pooling the three trials
  would count each participant three times as independent.

A test that cannot run (too few groups or values, a constant variable) is
recorded with its reason instead of stopping the report: a small pilot
export must still give every table. Library warnings are caught into the
same note (:func:`quietly`), so the terminal shows only the progress bar.
Independent-groups tests carry a design note when a group has fewer than
:data:`SMALL_N` units or the groups share participants (each participant
meets every human model): the paired tests are in :mod:`hcss.analysis.paired`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TypeVar

import pandas as pd

from hcss.analysis.decision_measures import SPLITS, unit_table
from hcss.analysis.exact import snapped
from hcss.analysis.instrument_measures import ALL_PARTICIPANTS
from hcss.analysis.load import GROUP_ORDER
from hcss.analysis.measures import MRT_MEASURE, measure_order
from hcss.analysis.posthoc import (
    PairwiseComparison,
    dunn_holm,
    tukey_hsd,
    tukey_kramer_ranks,
)
from hcss.analysis.stats import (
    MannWhitneyMethod,
    TestResult,
    kruskal_wallis,
    mann_whitney,
    spearman,
)

HUMAN_GROUPS = ("M1", "M2", "M3")
#: Below this many units per group a table says its p is fragile.
SMALL_N = 10
#: Fewer units than this in a group (or complete participants for a paired test) and the
#: test is not run: with one or two units a rank test's p cannot be small and its effect
#: size is degenerate (ε² = 1 with one unit per group, r = ±1 with one pair).
MIN_UNITS = 3
#: A Spearman correlation needs this many complete pairs (its interval needs n − 3 > 0).
MIN_PAIRS = 4
SIMULATION_PAIR = ("M1SIM", "M2SIM")
#: The pooled human correlation: one row per participant, the mean over the models met.
POOLED_HUMAN = "M1–M3 (participant means)"
POOLED_NOTE = (
    "one value per participant (the mean over the models they met): "
    "a participant's three trials are not independent observations"
)

#: (x, y) pairs correlated per unit; y is always the success rate.
CORRELATIONS = (
    ("decision_time_min", "success_rate"),
    ("request_frequency", "success_rate"),
    ("investigate_frequency", "success_rate"),
    ("decide_frequency", "success_rate"),
    ("abandon_frequency", "success_rate"),
    (MRT_MEASURE, "success_rate"),
)


@dataclass(frozen=True)
class OmnibusComparison:
    """A Kruskal-Wallis test and its post-hoc comparisons for one measure and split."""

    measure: str
    split: str
    family: str
    groups: tuple[str, ...]
    kruskal: TestResult | None
    posthoc: tuple[PairwiseComparison, ...]
    note: str = ""


@dataclass(frozen=True)
class TwoSampleComparison:
    """A Mann-Whitney test of two groups for one measure and split."""

    measure: str
    split: str
    groups: tuple[str, str]
    result: TestResult | None
    note: str = ""
    sizes: tuple[int, int] = (0, 0)


@dataclass(frozen=True)
class Correlation:
    """A Spearman correlation of two measures within one group of units."""

    x: str
    y: str
    group: str
    result: TestResult | None
    note: str = ""


Result = TypeVar("Result")


def quietly(function: Callable[..., Result], *arguments: object) -> tuple[Result, str]:
    """Call ``function`` with library warnings caught; return them as one note."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = function(*arguments)
    messages = sorted({str(warning.message).split("\n")[0] for warning in caught})
    return result, "; ".join(messages)


def join_notes(*notes: str) -> str:
    """Non-empty notes joined with semicolons."""
    return "; ".join(note for note in notes if note)


def design_note(measures: pd.DataFrame, measure: str, split: str, groups: Sequence[str]) -> str:
    """Warnings about the design: small groups, or groups sharing participants."""
    chosen = measures[
        (measures["measure"] == measure)
        & (measures["split"] == split)
        & measures["group"].isin(groups)
    ].dropna(subset=["value"])
    counts = chosen.groupby("group").size()
    notes = []
    small = [group for group in groups if 0 < counts.get(group, 0) < SMALL_N]
    if small:
        notes.append(f"n < {SMALL_N} in {', '.join(small)}")
    people = chosen[chosen["participant"].astype(str) != ""]
    shared = people.groupby("participant")["group"].nunique()
    if (shared > 1).any():
        notes.append(
            f"groups share {int((shared > 1).sum())} participants: independence does not hold "
            "(see the repeated-measures tests)"
        )
    return "; ".join(notes)


def _values(measures: pd.DataFrame, measure: str, split: str, group: str) -> list[float]:
    chosen = measures[
        (measures["measure"] == measure)
        & (measures["split"] == split)
        & (measures["group"] == group)
    ]
    values: list[float] = chosen["value"].dropna().tolist()
    return values


def measure_splits(measures: pd.DataFrame) -> list[tuple[str, str]]:
    """Every (measure, split) to test, in report order; MRT is per participant, not per model."""
    pairs = measures[["measure", "split"]].drop_duplicates()
    pairs = pairs[pairs["measure"].ne(MRT_MEASURE)]
    return sorted(
        pairs.itertuples(index=False, name=None),
        key=lambda pair: (measure_order(pair[0]), SPLITS.index(pair[1])),
    )


def _omnibus(
    measures: pd.DataFrame, measure: str, split: str, family: str, groups: Sequence[str]
) -> OmnibusComparison | None:
    by_group = {
        group: values.dropna().tolist() for group, values in measures.groupby("group")["value"]
    }  # ``measures`` is already this measure and split
    samples = {
        group: by_group[group] for group in groups if len(by_group.get(group, ())) >= MIN_UNITS
    }
    if len(samples) < 2:
        return None
    names = tuple(samples)
    design = design_note(measures, measure, split, names)
    try:
        result, caught = quietly(kruskal_wallis, samples)
    except ValueError as error:
        return OmnibusComparison(measure, split, family, names, None, (), str(error))
    posthoc, notes = [], [design, result.note, caught]
    for flavour in (tukey_kramer_ranks, dunn_holm, tukey_hsd):
        try:
            comparison, caught = quietly(flavour, samples)
        except ValueError as error:
            notes.append(f"{flavour.__name__}: {error}")
            continue
        posthoc.append(comparison)
        if comparison.note and comparison.note != result.note:
            notes.append(f"{flavour.__name__}: {comparison.note}")
        if caught:
            notes.append(f"{flavour.__name__}: {caught}")
    return OmnibusComparison(
        measure, split, family, names, result, tuple(posthoc), join_notes(*notes)
    )


def omnibus_comparisons(measures: pd.DataFrame) -> list[OmnibusComparison]:
    """Kruskal-Wallis families: human models, and all groups when both sources exist."""
    comparisons = []
    sources = set(measures["source"])
    all_groups = [group for group in GROUP_ORDER if group in set(measures["group"])]
    subsets = dict(list(measures.groupby(["measure", "split"], sort=False)))
    for measure, split in measure_splits(measures):
        subset = subsets[(measure, split)]  # filter once, not per group and test
        human = _omnibus(subset, measure, split, "human-collective models", HUMAN_GROUPS)
        if human is not None:
            comparisons.append(human)
        if len(sources) > 1:
            everyone = _omnibus(subset, measure, split, "all models", all_groups)
            if everyone is not None and any(g in SIMULATION_PAIR for g in everyone.groups):
                comparisons.append(everyone)
    return comparisons


def simulation_comparisons(
    measures: pd.DataFrame, method: MannWhitneyMethod = "auto", continuity: bool = True
) -> list[TwoSampleComparison]:
    """Mann-Whitney M1SIM vs M2SIM for every simulation measure and split.

    ``method`` and ``continuity`` pass through to :func:`mann_whitney`; the
    defaults reproduce R's ``wilcox.test``.
    """
    comparisons = []
    for measure, split in measure_splits(measures):
        first, second = (_values(measures, measure, split, g) for g in SIMULATION_PAIR)
        if not first and not second:
            continue
        if 0 < min(len(first), len(second)) < MIN_UNITS:
            continue
        try:
            result, caught = quietly(mann_whitney, first, second, method, continuity)
            note = join_notes(result.note, caught)
        except ValueError as error:
            result, note = None, str(error)
        small = [
            g for g, v in zip(SIMULATION_PAIR, (first, second), strict=True) if len(v) < SMALL_N
        ]
        note = join_notes(f"n < {SMALL_N} in {', '.join(small)}" if small else "", note)
        comparisons.append(
            TwoSampleComparison(
                measure, split, SIMULATION_PAIR, result, note, (len(first), len(second))
            )
        )
    return comparisons


def _with_mrt(units: pd.DataFrame, measures: pd.DataFrame) -> pd.DataFrame:
    mrt = measures[(measures["measure"] == MRT_MEASURE) & (measures["group"] == ALL_PARTICIPANTS)]
    if mrt.empty:
        return units
    scores = mrt.groupby("participant")["value"].mean()
    return units.assign(**{MRT_MEASURE: units["participant"].map(scores)})


def correlations(measures: pd.DataFrame) -> list[Correlation]:
    """Spearman correlations with success rate, per group and over participants' M1–M3 means."""
    units = unit_table(measures[measures["group"] != ALL_PARTICIPANTS], "overall")
    if units.empty:
        return []
    units = _with_mrt(units, measures)
    subsets = [
        (group, units[units["group"] == group])
        for group in GROUP_ORDER
        if group in set(units["group"])
    ]
    human = units[units["group"].isin(HUMAN_GROUPS) & (units["participant"].astype(str) != "")]
    if human["group"].nunique() > 1:
        means = human.drop(columns=["group", "source", "unit"]).groupby("participant").mean()
        # a participant without an MRT score is a gap (pd.NA in an object column): NaN first
        means = means.apply(pd.to_numeric, errors="coerce").astype(float)
        means = means.apply(snapped)  # equal means tie, as in R
        subsets.append((POOLED_HUMAN, means.reset_index()))
    results = []
    for x, y in CORRELATIONS:
        for group, subset in subsets:
            if x not in subset.columns or y not in subset.columns:
                continue
            if (subset[x].notna() & subset[y].notna()).sum() < MIN_PAIRS:
                continue
            try:
                result, caught = quietly(spearman, subset[x], subset[y])
                pooled = POOLED_NOTE if group == POOLED_HUMAN else ""
                note = join_notes(pooled, result.note, caught)
            except ValueError as error:
                result, note = None, str(error)
            results.append(Correlation(x, y, group, result, note))
    return results
