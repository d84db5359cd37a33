"""The compiled engine's outcomes agree with the pre-change engine's (issue 11).

The reference (tests/experiments/data/reference_outcomes.csv, one row per
decision) was written by the numpy engine of commit 5718869 with

    python -m hcss.experiments.equivalence write tests/experiments/data/reference_outcomes.csv

on 28 scenarios × 4 runs × {M1, M2} at PRE_CHANGE_PARAMS (pinned there, not the
defaults, which the fidelity work changes). Random streams differ, so the
comparison is statistical: per model × split × measure, a two-sided
Mann-Whitney U on per-trial values, family alpha 0.01 (Bonferroni over the
12 comparisons), and means within 0.10 (success) or 15 % (decision time).
The full-size comparison (28 × 10 new runs) is in `make bench`.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hcss.experiments import equivalence as eq
from hcss.simulation.params import Params

REFERENCE = Path(__file__).parent / "data" / "reference_outcomes.csv"


def test_the_pinned_parameters_are_todays_values_except_the_fidelity_readings():
    # Every pre-change value is pinned explicitly: a changed default cannot leak in.
    pinned = eq.pinned_params()
    for name, value in eq.PRE_CHANGE_PARAMS.items():
        if name in Params.__dataclass_fields__:
            assert getattr(pinned, name) == value, name
    assert set(Params.__dataclass_fields__) <= set(eq.PRE_CHANGE_PARAMS), (
        "a new parameter must be pinned at the value that reproduces the pre-change rules"
    )


def test_reference_holds_the_reduced_experiment():
    rows = eq.read_reference(REFERENCE)
    assert len({r["trial_id"] for r in rows}) == 28 * 4 * 2
    assert {r["model"] for r in rows} == {"M1", "M2"}
    assert len(rows) == 28 * 4 * 2 * 12


@pytest.mark.slow
def test_new_engine_outcome_distributions_agree_with_the_reference():
    reference = eq.read_reference(REFERENCE)
    new = eq.run_outcomes(scenarios=28, runs=2, workers=1)
    results = eq.compare(reference, new)
    assert len(results) == 12
    assert all(r.agrees for r in results), "\n".join(r.line() for r in results)


def test_the_comparison_detects_a_different_engine():
    """A sample with M1's easy successes halved must be reported as different."""
    reference = eq.read_reference(REFERENCE)
    seen: set[str] = set()
    altered = []
    for r in reference:
        row = dict(r)
        if row["model"] == "M1" and row["difficulty"] == "easy" and row["correct"]:
            key = row["trial_id"] + str(len(seen))
            seen.add(key)
            row["correct"] = len(seen) % 2 == 0
        altered.append(row)
    results = {(r.model, r.split, r.measure): r for r in eq.compare(reference, altered)}
    assert not results[("M1", "easy", "success_rate")].agrees
    assert results[("M2", "easy", "success_rate")].agrees
