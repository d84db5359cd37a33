"""Calibration: the sensing radius to the study's g(d), r_msg to M1's published 2.46 min."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import calibrate as cal
from hcss.simulation import Params


def test_first_encounters_come_no_later_with_a_larger_radius() -> None:
    radii = np.array([2.0, 5.0, 20.0])
    first = cal.first_encounters(Params(), (150.0, 250.0, 350.0), radii, seed=3, limit_s=1200)
    assert first.shape == (3, 3)
    assert np.all(np.diff(first, axis=0) <= 0)  # a walk within 2 m is also within 5 m
    assert np.all(first >= Params().dt_s)


def test_the_default_radius_reproduces_the_study_discovery_times() -> None:
    """With params.py's radius, a collective's first explorer finds sites after about 1/g(d).

    Pooled over the three distances (48 walks), the geometric mean ratio of
    measured to published times lies within 0.7–1.4 (its standard error is
    about 0.15 in log terms; the fit itself minimised the log error).
    """
    p = Params()
    distances = (150.0, 250.0, 350.0)
    walks = np.stack(
        [
            cal.first_encounters(p, distances, np.array([p.sensing_radius_m]), seed=500 + i)[0]
            for i in range(16)
        ]
    )
    published = 1.0 / p.discovery_rate(np.array(distances))
    ratio = math.exp(float(np.mean(np.log(walks.mean(axis=0) / published))))
    assert 0.7 <= ratio <= 1.4, (walks.mean(axis=0), published)


def test_the_rate_fit_finds_the_rate_of_a_known_curve(monkeypatch: pytest.MonkeyPatch) -> None:
    """A world whose M1 takes 5/r_msg minutes needs r_msg = 5/2.46 for the study's time."""
    calls: list[float] = []

    def fake(params: Params, scenarios: int, runs: int, workers: int, seed: int = 0):
        calls.append(params.message_rate)
        return 5.0 / params.message_rate + 0.3 / params.message_rate**2, 0.01

    monkeypatch.setattr(cal, "m1_decision_time", fake)
    fit = cal.fit_message_rate(Params().with_changes(message_rate=1.0), iterations=5)
    # Root of 5/r + 0.3/r² = 2.46, by hand: r = (5 + √(25 + 4·2.46·0.3)) / (2·2.46) = 2.0908.
    truth = 2.0908
    assert fit.rate == pytest.approx(truth, rel=0.01)
    assert len(calls) == 5
    assert "| 1.000 |" in cal.rate_table(fit)


def test_the_rate_is_interpolated_between_the_two_nearest_measurements() -> None:
    """The P4 calibration's measurements: 2.33 min at 1.700/s, 2.57 at 1.616/s, 1.51 at 2.550/s.

    By hand: slope = ln(2.57/2.33)/ln(1.616/1.700) = -1.933;
    r = 1.700·exp(ln(2.46/2.33)/-1.933) = 1.653 (the line through 1.616 gives the same).
    """
    tried = [(1.7, 2.33, 0.08), (2.55, 1.51, 0.03), (1.616, 2.57, 0.08)]
    assert cal.interpolate_rate(tried, 2.46) == pytest.approx(1.653, abs=0.002)
    # A rising curve (noise) falls back to the nearest measurement.
    assert cal.interpolate_rate([(1.0, 2.5, 0.1), (2.0, 2.6, 0.1)], 2.46) == 1.0


@pytest.mark.parametrize(
    "args",
    [
        ["--runs", "0"],
        ["--radius-runs", "1"],
        ["--discovery", "psychic"],
        ["--workers", "-3"],
        ["--iterations", "99999999999999999999999"],
        ["--foreign-targets", "own\x00only"],
    ],
)
def test_calibrate_refuses_bad_options_without_a_traceback(args: list[str]) -> None:
    result = CliRunner().invoke(main, ["simulate", "calibrate", *args])
    assert result.exit_code == 2
    assert "Traceback" not in result.output
    assert "Error" in result.output
