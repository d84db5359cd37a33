"""§11's cells measured on a synthetic team's rows, as the calibration reads them."""

from __future__ import annotations

import math

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
