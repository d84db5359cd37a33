"""`hcss simulate sweep` and `hcss analyze` on its output (issue 11)."""

from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import experiment as exp
from hcss.experiments import sweep as sw
from hcss.simulation import DECISION_COLUMNS
from hcss.simulation.presets import DEFAULT_PRESET, preset_params

GRID = ["--param", "message_rate=0.5,1,2", "--param", "quorum_k=10,15,20"]
REDUCED = ["--scenarios", "1", "--runs", "1", "--models", "M1,M2", "--workers", "1"]


def _sweep(out: Path, *extra: str):
    return CliRunner().invoke(
        main, ["simulate", "sweep", *GRID, *REDUCED, "--out", str(out), *extra]
    )


def _rows(path: Path) -> list[dict]:
    with path.open(newline="") as handle:
        return list(csv.DictReader(handle))


@pytest.fixture(scope="module")
def swept(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("sweep") / "out"
    result = _sweep(out)
    assert result.exit_code == 0, result.output
    assert "9 cells × 2 runs" in result.output
    return out


def test_a_3x3_sweep_writes_one_row_per_decision_with_the_cells_values(swept):
    rows = _rows(swept / "decisions.csv")
    assert list(rows[0]) == ["message_rate", "quorum_k", *DECISION_COLUMNS]
    cells = {(r["message_rate"], r["quorum_k"]) for r in rows}
    assert cells == {(m, k) for m in ("0.5", "1.0", "2.0") for k in ("10", "15", "20")}
    assert len(rows) == 9 * 2 * 12  # cells × trials × decisions per trial
    assert len(list((swept / "cells").glob("*.csv"))) == 9


def test_each_cell_is_the_experiment_at_its_parameter_values(swept):
    """The (2, 10) cell's rows are exactly a direct run of the experiment at those values,
    every other value the default preset's (named in the manifest)."""
    assert json.loads((swept / "sweep.json").read_text())["preset"] == DEFAULT_PRESET
    at_cell = preset_params(DEFAULT_PRESET).with_changes(message_rate=2.0, quorum_k=10)
    # The scenarios too are drawn under the cell's params (the preset's layout reading).
    jobs = exp.jobs_for(exp.experiment_scenarios(1, params=at_cell), ["M1", "M2"], 1)
    direct = exp.run_jobs(jobs, params=at_cell)
    cell = [
        r
        for r in _rows(swept / "decisions.csv")
        if (r["message_rate"], r["quorum_k"]) == ("2.0", "10")
    ]
    assert [r["end_s"] for r in cell] == [str(d["end_s"]) for d in direct]
    assert [r["chosen_target"] for r in cell] == [str(d["chosen_target"] or "") for d in direct]


def test_an_interrupted_sweep_resumes_skipping_the_cells_written(swept, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(swept, out)
    (out / "cells" / "message_rate=1.0__quorum_k=15.csv").unlink()
    (out / "decisions.csv").unlink()
    result = _sweep(out)
    assert result.exit_code == 0, result.output
    assert "8 cell(s) already written" in result.output and "1 cell(s) run" in result.output
    assert (out / "decisions.csv").read_text() == (swept / "decisions.csv").read_text()


def test_resuming_with_other_settings_is_refused(swept, tmp_path):
    out = tmp_path / "copy"
    shutil.copytree(swept, out)
    before = (out / "decisions.csv").read_text()
    result = CliRunner().invoke(
        main, ["simulate", "sweep", *GRID, *REDUCED[:2], "--runs", "2", "--out", str(out)]
    )
    assert result.exit_code == 2 and "holds another sweep" in result.output
    assert "Traceback" not in result.output and (out / "decisions.csv").read_text() == before


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("bogus=1,2", "not a simulation parameter"),
        ("message_rate=abc", "message_rate='abc'"),
        ("message_rate=-1", "message_rate"),
        ("message_rate=nan", "finite"),
        ("quorum_k=1.5", "quorum_k='1.5'"),
        ("message_rate=1,1", "twice"),
        ("message_rate", "name=value1"),
        ("target_values=1", "cannot be swept"),
        ("discovery=spatial,\x00", "discovery"),
        ("discovery=psychic", "discovery"),
    ],
)
def test_bad_parameters_are_refused_before_anything_runs(tmp_path, spec, message):
    out = tmp_path / "never"
    result = CliRunner().invoke(
        main, ["simulate", "sweep", "--param", spec, *REDUCED, "--out", str(out)]
    )
    assert result.exit_code == 2, result.output
    assert message in result.output and "Traceback" not in result.output
    assert not out.exists()


def test_a_huge_grid_is_refused(tmp_path):
    values = ",".join(str(v) for v in range(1, 200))
    result = CliRunner().invoke(
        main,
        [
            "simulate",
            "sweep",
            "--param",
            f"quorum_k={values}",
            "--param",
            f"neighbour_draws={values}",
        ]
        + REDUCED
        + ["--out", str(tmp_path / "never")],
    )
    assert result.exit_code == 2 and "limited to" in result.output
    assert not (tmp_path / "never").exists()


def test_analyze_draws_heat_maps_and_a_table_per_cell(swept, tmp_path):
    report = tmp_path / "report"
    result = CliRunner().invoke(main, ["analyze", str(swept), "--out", str(report)])
    assert result.exit_code == 0, result.output
    assert (report / "figures" / "sweep_message_rate__quorum_k.png").stat().st_size > 10_000
    table = _rows(report / "tables" / "sweep_cells.csv")
    assert len(table) == 9 * 2
    # Hand computation from the decisions table: M1 at (0.5, 20), easy decisions.
    rows = [
        r
        for r in _rows(swept / "decisions.csv")
        if (r["message_rate"], r["quorum_k"], r["model"]) == ("0.5", "20", "M1")
    ]
    easy = [r["correct"] == "true" for r in rows if r["difficulty"] == "easy"]  # one trial
    minutes = sum(float(r["decision_time_s"]) for r in rows) / len(rows) / 60
    row = next(
        r for r in table if (r["message_rate"], r["quorum_k"], r["model"]) == ("0.5", "20", "M1")
    )
    assert float(row["success_easy"]) == pytest.approx(sum(easy) / len(easy))
    assert float(row["decision_time_min"]) == pytest.approx(minutes)
    assert int(row["trials"]) == 1 and int(row["decisions"]) == 12


def test_analyze_refuses_a_broken_sweep_directory(tmp_path):
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / sw.MANIFEST).write_text("{not json")
    result = CliRunner().invoke(
        main, ["analyze", str(tmp_path / "bad"), "--out", str(tmp_path / "r")]
    )
    assert result.exit_code == 1 and "not a complete sweep output" in result.output
    assert "Traceback" not in result.output


@pytest.mark.slow
def test_the_same_sweep_runs_on_a_dask_local_cluster(tmp_path):
    pytest.importorskip("dask.distributed")
    axes = (sw.parse_axis("quorum_k=10,20"),)
    plan = sw.Sweep(axes, scenarios=1, runs=1, models=("M1",), seed=20_150_000)
    sw.run_sweep(plan, tmp_path / "local", workers=1)
    sw.run_sweep(plan, tmp_path / "dask", workers=2, dask_address="local")
    assert (tmp_path / "dask" / "decisions.csv").read_text() == (
        tmp_path / "local" / "decisions.csv"
    ).read_text()
