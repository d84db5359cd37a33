"""§11's cells measured on a synthetic team's rows, as the calibration reads them."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hcss.experiments import study_teams as teams


def _decision(index: int, start: float, end: float, difficulty: str) -> dict:
    return {
        "model": "M1",
        "trial_id": "t",
        "collective": "I",
        "decision_index": index,
        "difficulty": difficulty,
        "correct": True,
        "start_s": start,
        "end_s": end,
        "decision_time_s": end - start,
        "n_investigate": 0,
        "n_decide": 0,
        "n_abandon": 0,
        "n_interventions": 0,
    }


def _request(time: float) -> dict:
    return {
        "model": "M1",
        "trial_id": "t",
        "collective": "I",
        "sim_time_s": time,
        "kind": "investigate",
    }


def _click(time: float, kind: str) -> dict:
    return {
        "model": "M1",
        "trial_id": "t",
        "collective": "I",
        "attended": "I",
        "sim_time_s": time,
        "kind": kind,
    }


def test_observations_are_the_share_of_decisions_with_a_click_of_that_kind() -> None:
    """§11's observation cells are 0/100 per decision (each SD is a 0/100 variable's, and
    M1's difficult collective and target cells add to more than 100): a decision with one
    hub click among three requests counts 100, not 25, and one with no action counts 0."""
    decisions = [
        _decision(1, 0.0, 120.0, "easy"),
        _decision(2, 120.0, 300.0, "difficult"),
        _decision(3, 300.0, 400.0, "difficult"),
    ]
    requests = [_request(10.0), _request(20.0), _request(30.0), _request(150.0)]
    clicks = [_click(40.0, "collective"), _click(160.0, "collective"), _click(170.0, "target")]
    measured = teams.measure(decisions, requests, clicks, [])
    assert measured[("observations_pct", "M1", "collective/easy")].mean == 100.0
    assert measured[("observations_pct", "M1", "collective/difficult")].mean == 50.0
    assert measured[("observations_pct", "M1", "target/difficult")].mean == 50.0
    overall = measured[("observations_pct", "M1", "collective/overall")]
    assert overall.n == 3 and overall.mean == pytest.approx(200 / 3)


def test_the_studys_observation_sds_are_those_of_a_0_100_variable() -> None:
    """The evidence for the reading above, kept beside it: every SD is sqrt(p(100 - p))
    within the n - 1 correction (n >= 144 decisions per cell)."""
    for cell in teams.STUDY_TEAMS:
        if cell.measure == "observations_pct":
            binary = math.sqrt(cell.mean * (100.0 - cell.mean))
            assert binary <= cell.sd <= binary * math.sqrt(144 / 143) + 0.01, cell


def test_decisions_per_trial_count_a_trial_that_made_none() -> None:
    """§11's trials each made 12 decisions: a trial is counted from any of its rows, so one
    that made no decision by its time limit counts 0, not nothing."""
    decisions = [_decision(1, 0.0, 120.0, "easy"), _decision(2, 120.0, 300.0, "difficult")]
    idle = {"model": "M1", "trial_id": "u", "level": 1, "correct": True}
    measured = teams.measure(decisions, [_request(10.0)], [], [idle])
    key = ("decisions", "M1", "per trial")
    assert (measured[key].n, measured[key].mean) == (2, 1.0)
    assert next(c for c in teams.STUDY_TEAMS if c.key == key).mean == 12.0


def test_the_chance_a_perfect_population_meets_a_cell_agrees_with_drawing_both_samples() -> None:
    """`chance_within` against a simulation of the study and a block drawn from the same
    people: success in M1's difficult decisions as 0/100 outcomes over 146 decisions each
    (28 participants' share of §11's 439 difficult decisions of 1,008), and M3's
    interventions as counts with §11's mean and SD (negative binomial) over 28 participants
    each; the fraction of draws whose means lie within the band."""
    rng = np.random.default_rng(20261207)
    cells = {cell.key: cell for cell in teams.STUDY_TEAMS}
    draws = 40_000
    success = cells[("success_pct", "M1", "difficult")]
    p = success.mean / 100.0
    a, b = (100.0 * rng.binomial(146, p, draws) / 146 for _ in range(2))
    drawn = float(np.mean(np.abs(a - b) <= success.band))
    assert abs(teams.chance_within(success, 28) - drawn) < 0.015
    counts = cells[("interventions", "M3", "participant")]
    size = counts.mean**2 / (counts.sd**2 - counts.mean)
    a, b = (
        rng.negative_binomial(size, size / (size + counts.mean), (draws, 28)).mean(axis=1)
        for _ in range(2)
    )
    drawn = float(np.mean(np.abs(a - b) <= counts.band))
    assert abs(teams.chance_within(counts, 28) - drawn) < 0.015
    assert teams.chance_within(cells[("decisions", "M1", "per trial")], 28) == 1.0  # SD 0


def test_a_perfect_population_meets_more_cells_on_a_larger_block_but_not_surely_all() -> None:
    expected_28, all_28 = teams.ceiling(28)
    expected_56, all_56 = teams.ceiling(56)
    assert len(teams.STUDY_TEAMS) - 3 < expected_28 < expected_56 < len(teams.STUDY_TEAMS)
    assert all_28 < all_56 < 0.5


def _clustered_rows(outcomes: list[list[bool]]) -> dict:
    """M1 decisions, one list of outcomes per trial, as `values_by_trial` groups them."""
    decisions = [
        _decision(i, 60.0 * i, 60.0 * (i + 1), "easy") | {"trial_id": f"t{t}", "correct": ok}
        for t, trial in enumerate(outcomes)
        for i, ok in enumerate(trial)
    ]
    return teams.values_by_trial(decisions, [], [], [])


def _linearised_design_effect(trials: list[list[float]]) -> float:
    """The textbook variance of a ratio mean over clusters (Cochran 1977, eq. 6.13, with
    T/(T - 1)), over the variance of a mean of independent values: computed in closed
    form, apart from the bootstrap it checks."""
    sums = np.array([sum(t) for t in trials])
    sizes = np.array([len(t) for t in trials], dtype=float)
    every = np.concatenate([np.asarray(t, dtype=float) for t in trials])
    mean, n, count = every.mean(), every.size, len(trials)
    clustered = count / (count - 1) * float(((sums - mean * sizes) ** 2).sum()) / n**2
    return clustered / (float(every.var(ddof=1)) / n)


def test_a_design_effect_is_the_clustered_variance_over_the_independent_one() -> None:
    """Trials whose 12 decisions all succeed or all fail (a person's decisions alike):
    the design effect is about 12 (Kish: 1 + (m - 1) rho with rho = 1), and agrees with the
    closed form; decisions drawn independently give about 1; trials that each succeed on
    exactly half give 0 (no spread between people)."""
    alike = [[t % 2 == 0] * 12 for t in range(28)]
    rng = np.random.default_rng(7)
    independent = [list(rng.random(12) < 0.6) for _ in range(28)]
    halves = [[i % 2 == 0 for i in range(12)] for _ in range(28)]
    key = ("success_pct", "M1", "easy")
    for trials, expected in ((alike, 12.0), (independent, 1.0), (halves, 0.0)):
        values = [[100.0 * ok for ok in trial] for trial in trials]
        effect = teams.design_effects(_clustered_rows(trials), replications=20_000)[key]
        assert effect == pytest.approx(_linearised_design_effect(values), rel=0.05, abs=0.02)
        assert effect == pytest.approx(expected, rel=0.1, abs=0.6)


def test_a_trial_level_cell_has_no_design_effect_and_one_raises_the_chance_of_a_miss() -> None:
    per_trial = teams.values_by_trial(
        [_decision(1, 0.0, 60.0, "easy") | {"trial_id": f"t{t}", "n_interventions": t % 5}
         for t in range(28)], [], [], []
    )  # fmt: skip
    effects = teams.design_effects(per_trial, replications=20_000)
    assert effects[("interventions", "M1", "participant")] == pytest.approx(1.0, abs=0.1)
    assert effects[("decisions", "M1", "per trial")] == 1.0  # no spread: nothing to cluster
    wide = next(c for c in teams.STUDY_TEAMS if c.key == ("success_pct", "M1", "difficult"))
    assert teams.chance_within(wide, 28, 2.0) < teams.chance_within(wide, 28)
    expected, every = teams.ceiling(28, {wide.key: 2.0})
    assert expected < teams.ceiling(28)[0] and every < teams.ceiling(28)[1]
