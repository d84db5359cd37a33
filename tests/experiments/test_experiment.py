"""The simulation-only experiment: batch runs, Dask, outputs and the CLI."""

from __future__ import annotations

import csv

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import experiment as exp
from hcss.simulation import DECISION_COLUMNS
from hcss.simulation.presets import DEFAULT_PRESET


@pytest.fixture(scope="module")
def tiny_jobs() -> list[exp.Job]:
    return exp.jobs_for(exp.experiment_scenarios(2), ["M1"], runs=1)


def test_scenarios_alternate_easy_and_difficult_first():
    scenarios = exp.experiment_scenarios(4)
    assert [s.first_section for s in scenarios] == ["easy", "difficult", "easy", "difficult"]
    assert len({s.seed for s in scenarios}) == 4


def test_process_pool_and_serial_runs_give_the_same_rows(tiny_jobs):
    serial = exp.run_jobs(tiny_jobs, workers=1)
    pooled = exp.run_jobs(tiny_jobs, workers=2)
    assert serial == pooled and len(serial) == 24
    assert all(list(row) == list(DECISION_COLUMNS) for row in serial)


@pytest.mark.slow
def test_dask_local_cluster_runs_the_same_jobs(tiny_jobs):
    pytest.importorskip("dask.distributed")
    assert exp.run_jobs(tiny_jobs, workers=1, dask_address="local") == exp.run_jobs(
        tiny_jobs, workers=1
    )


def test_summary_is_the_analysis_of_the_same_decisions_file(tmp_path):
    """One unit of analysis (the scenario, runs averaged) and one writer for both commands."""
    import pandas as pd

    from hcss.analysis.report import run_analysis
    from hcss.analysis.summary import summarise_decisions
    from tests.support.synthetic import simulation_decisions

    rows = simulation_decisions(scenarios=4, runs=3).to_dict("records")
    exp.write_decisions(rows, tmp_path / "decisions.csv")
    markdown = summarise_decisions(tmp_path / "decisions.csv")
    assert "| M1 | overall | 4 |" in markdown  # 4 scenarios, not 12 runs
    summary = pd.read_csv(tmp_path / "summary.csv")
    run_analysis([tmp_path / "decisions.csv"], tmp_path / "report", progress=False)
    for measure in ("success_rate", "decision_time_min"):
        analysed = pd.read_csv(tmp_path / "report" / "tables" / f"descriptive_{measure}.csv")
        analysed["model"] = analysed["group"].str.removesuffix("SIM")
        merged = summary[summary["measure"] == measure].merge(analysed, on=["model", "split"])
        assert len(merged) == 6  # two models x three splits
        for column in ("n", "mean", "sd", "median", "minimum", "maximum"):
            assert (merged[f"{column}_x"] == merged[f"{column}_y"]).all(), (measure, column)


def test_experiment_command_writes_the_decisions_table_and_summary(tmp_path):
    result = CliRunner().invoke(
        main,
        [
            "simulate",
            "experiment",
            "--scenarios",
            "1",
            "--runs",
            "1",
            "--models",
            "M2",
            "--workers",
            "1",
            "--out",
            str(tmp_path),
        ],
    )
    assert result.exit_code == 0, result.output
    with (tmp_path / "decisions.csv").open() as handle:
        rows = list(csv.DictReader(handle))
    assert list(rows[0]) == list(DECISION_COLUMNS) and len(rows) == 12
    assert {r["source"] for r in rows} == {"simulation"} and {r["model"] for r in rows} == {"M2"}
    assert "| M2 | overall |" in (tmp_path / "summary.md").read_text()
    # Without --preset the command runs the default, named in what it prints and writes.
    assert f"preset {DEFAULT_PRESET}." in result.output
    assert f"preset {DEFAULT_PRESET}." in (tmp_path / "summary.md").read_text()


def test_unknown_models_are_refused_without_a_traceback(tmp_path):
    result = CliRunner().invoke(
        main, ["simulate", "experiment", "--models", "M9", "--out", str(tmp_path)]
    )
    assert result.exit_code == 2 and "models must be among" in result.output
    assert "Traceback" not in result.output and not (tmp_path / "decisions.csv").exists()


def test_demo_runs_a_paced_trial_and_prints_events():
    result = CliRunner().invoke(
        main, ["simulate", "demo", "--speed", "5000", "--minutes", "4", "--model", "M1"]
    )
    assert result.exit_code == 0, result.output
    assert "discovered" in result.output and "decisions" in result.output


def test_experiment_changes_values_with_set_and_prints_the_loss_and_the_shape(tmp_path):
    args = ["simulate", "experiment", "--scenarios", "2", "--runs", "1", "--workers", "1"]
    changes = ["--set", "m2_modulation_uses=recruitment+inhibition", "--set", "message_rate=2.25"]
    result = CliRunner().invoke(main, [*args, *changes, "--out", str(tmp_path)])
    assert result.exit_code == 0, result.output
    assert "with m2_modulation_uses=recruitment+inhibition, message_rate=2.25." in result.output
    assert "message_rate=2.25" in (tmp_path / "summary.md").read_text()
    assert "Under the study's unit: loss" in result.output
    assert "| M2 | easy |" in result.output and "slowest quarter" in result.output
    for bad in ("message_rate=fast", "bogus=1", "m2_modulation_uses=sometimes", "noequals"):
        refused = CliRunner().invoke(main, [*args, "--set", bad, "--out", str(tmp_path / "x")])
        assert refused.exit_code == 2 and "Traceback" not in refused.output, bad
        assert not (tmp_path / "x").exists()


def test_parse_changes_reads_numbers_sets_and_readings():
    assert exp.parse_changes(
        ["message_rate=2.5", "m2_modulation_uses=recruitment", "m2_d_min=nearest_site"]
    ) == {
        "message_rate": 2.5,
        "m2_modulation_uses": ("recruitment",),
        "m2_d_min": "nearest_site",
    }
    assert exp.parse_changes(["n_agents=50"]) == {"n_agents": 50}


def test_decision_shape_says_whether_slow_decisions_fail_more():
    from hcss.experiments.study_targets import decision_shape

    rows = [
        {"model": "M2", "difficulty": "easy", "decision_time_s": 60 * t, "correct": c}
        for t, c in (
            (1, True),
            (2, True),
            (3, True),
            (4, False),
            (5, True),
            (6, False),
            (7, False),
            (8, False),
        )
    ]
    shape = decision_shape(rows)[("M2", "easy")]
    assert shape.decisions == 8
    assert shape.right_time_min == pytest.approx((1 + 2 + 3 + 5) / 4)
    assert shape.wrong_time_min == pytest.approx((4 + 6 + 7 + 8) / 4)
    assert (shape.fastest_quarter_pct, shape.slowest_quarter_pct) == (100.0, 0.0)
    assert shape.slow_fail_more
