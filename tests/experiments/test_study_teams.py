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
