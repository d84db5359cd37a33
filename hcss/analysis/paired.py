"""Repeated-measures comparisons of the human models, per measure and split.

Each participant meets M1, M2 and M3, so the three groups are the same
people. For every measure with per-model values, this runs Friedman's test
on the participants who have all three, with Kendall's W, and the three
pairwise Wilcoxon signed-rank tests, Holm-adjusted within the measure and
split (:mod:`hcss.analysis.repeated` computes each test as R does).
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import pandas as pd

from hcss.analysis.comparisons import (
    HUMAN_GROUPS,
    MIN_UNITS,
    SMALL_N,
    join_notes,
    measure_splits,
    quietly,
)
from hcss.analysis.r_distributions import holm
from hcss.analysis.repeated import friedman, paired_wilcoxon
from hcss.analysis.stats import TestResult


@dataclass(frozen=True)
class PairedTest:
    """One pairwise signed-rank test with its Holm-adjusted p."""

    group_a: str
    group_b: str
    result: TestResult
    p_holm: float


@dataclass(frozen=True)
class RepeatedComparison:
    """Friedman and pairwise Wilcoxon tests of one measure and split."""

    measure: str
    split: str
    groups: tuple[str, ...]
    participants: int
    friedman: TestResult | None
    pairs: tuple[PairedTest, ...]
    note: str = ""


def participant_blocks(measures: pd.DataFrame, measure: str, split: str) -> pd.DataFrame:
    """One row per participant, one column per human model, only complete rows."""
    chosen = measures[
        (measures["measure"] == measure)
        & (measures["split"] == split)
        & measures["group"].isin(HUMAN_GROUPS)
        & (measures["participant"].astype(str) != "")
    ]
    wide = chosen.pivot_table(index="participant", columns="group", values="value", aggfunc="mean")
    groups = [group for group in HUMAN_GROUPS if group in wide.columns]
    return wide[groups].dropna()


def _compare(measures: pd.DataFrame, measure: str, split: str) -> RepeatedComparison | None:
    blocks = participant_blocks(measures, measure, split)
    groups = tuple(blocks.columns)
    if len(groups) < 2 or len(blocks) < MIN_UNITS:
        return None
    n = len(blocks)
    notes = [f"n = {n} < {SMALL_N} participants with every model" if n < SMALL_N else ""]
    result = None
    if len(groups) >= 3:
        try:
            result, caught = quietly(friedman, blocks)
            notes += [result.note, caught]
        except ValueError as error:
            notes.append(str(error))
    tests = []
    for a, b in combinations(groups, 2):
        try:
            test, caught = quietly(paired_wilcoxon, blocks[a], blocks[b])
        except ValueError as error:
            notes.append(f"{a}–{b}: {error}")
            continue
        tests.append((a, b, test))
        notes.append(f"{a}–{b}: {caught}" if caught else "")
    adjusted = list(holm([test.p for _, _, test in tests])) if tests else []
    pairs = tuple(
        PairedTest(a, b, test, float(p)) for (a, b, test), p in zip(tests, adjusted, strict=True)
    )
    unique = list(dict.fromkeys(notes))
    return RepeatedComparison(measure, split, groups, n, result, pairs, join_notes(*unique))


def repeated_comparisons(measures: pd.DataFrame) -> list[RepeatedComparison]:
    """Friedman + pairwise Wilcoxon for every measure and split with per-model values."""
    results = []
    human = measures[
        measures["group"].isin(HUMAN_GROUPS) & (measures["participant"].astype(str) != "")
    ]
    subsets = dict(list(human.groupby(["measure", "split"], sort=False)))
    for measure, split in measure_splits(measures):
        if (measure, split) not in subsets:
            continue
        comparison = _compare(subsets[(measure, split)], measure, split)
        if comparison is not None:
            results.append(comparison)
    return results
