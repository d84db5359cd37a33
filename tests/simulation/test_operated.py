"""Operated experiments: scripted operators at a human's pace, through the request API."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.analysis.load import load_inputs
from hcss.experiments import experiment as exp
from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation.operators import (
    HumanPace,
    InvestigateThenDecide,
    OperatedRun,
    operator_named,
)


def _operated(pace: HumanPace | None, until_s: float = 900.0, seed: int = 5) -> OperatedRun:
    sim = Simulation(Scenario.generate(seed), "M3")
    run = OperatedRun(sim, InvestigateThenDecide(abandon_below=0.15), interval_s=10.0, pace=pace)
    run.run(until_s=until_s)
    return run


def test_a_human_pace_bounds_the_request_rate() -> None:
    pace = HumanPace(glance_interval_s=2.0, reaction_time_s=0.0, requests_per_minute=4.0)
    run = _operated(pace)
    steps = np.array([step for step, _ in run.log], dtype=float) * Params().dt_s
    assert steps.size > 4
    # Token bucket of one minute's worth: any 60 s window holds at most 2 × 4 requests,
    # and the whole run at most 4 per minute plus the initial bucket.
    for start in steps:
        assert np.sum((steps >= start) & (steps < start + 60.0)) <= 8
    assert steps.size <= 4 + 4 * 900 / 60


def test_requests_arrive_a_reaction_time_after_the_glance() -> None:
    """With glances every 30 s and a 7 s reaction, requests land only at 30·n + 7 s."""
    pace = HumanPace(glance_interval_s=30.0, reaction_time_s=7.0, requests_per_minute=600.0)
    run = _operated(pace, until_s=600.0)
    times = {step * Params().dt_s for step, _ in run.log}
    assert times
    assert all(t % 30.0 == 7.0 for t in times), sorted(times)


def test_attention_to_one_collective_at_a_time() -> None:
    pace = HumanPace(glance_interval_s=5.0, reaction_time_s=0.0, requests_per_minute=600.0)
    run = _operated(pace, until_s=600.0)
    by_step: dict[int, set[int]] = {}
    for step, command in run.log:
        by_step.setdefault(step, set()).add(command.collective)
    assert by_step
    assert all(len(collectives) == 1 for collectives in by_step.values())
    # Round robin: every collective gets the operator's attention.
    assert set().union(*by_step.values()) == {0, 1, 2, 3}


def test_without_a_pace_the_policy_acts_on_every_collective_at_once() -> None:
    run = _operated(None, until_s=300.0)
    # Some glance issues requests to several collectives in the same step (which
    # glance first does depends on the random stream, so any glance may show it).
    by_step: dict[int, set[int]] = {}
    for step, command in run.log:
        by_step.setdefault(step, set()).add(command.collective)
    assert max(len(collectives) for collectives in by_step.values()) > 1


def test_an_unknown_operator_or_a_negative_pace_is_refused() -> None:
    with pytest.raises(ValueError, match="operator must be one of"):
        operator_named("clippy")
    with pytest.raises(ValueError):
        HumanPace(requests_per_minute=0)


def test_operated_rows_feed_the_human_team_analysis() -> None:
    """Operated decisions are study rows of simulated participants, groups M1/M2/M3 (not SIM)."""
    params = Params().with_changes(decisions_per_section=1)
    scenarios = exp.experiment_scenarios(2)
    rows = exp.run_jobs(exp.jobs_for(scenarios, ["M1", "M3"], 1, "human"), 1, params=params)
    assert {r["source"] for r in rows} == {"study"}
    assert all(r["participant"].startswith("simop-human-exp") for r in rows)
    assert sum(r["n_requests"] for r in rows) > 0
    path_rows = rows
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "decisions.csv"
        exp.write_decisions(path_rows, path)
        tables = load_inputs([path], include_pilot=True)
    assert set(tables.decisions["group"]) == {"M1", "M3"}
