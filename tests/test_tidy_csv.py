"""One CSV writer, one cell rule: a missing value is an empty cell in every table hcss writes."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest

from hcss import tidy_csv
from hcss.experiments import equivalence as eq
from hcss.experiments import experiment as exp
from hcss.experiments import sweep as sw
from hcss.simulation import DECISION_COLUMNS


def _cells(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as handle:
        return list(csv.DictReader(handle))


@pytest.mark.parametrize(
    ("value", "written"),
    [(None, ""), (math.nan, ""), (True, "true"), (False, "false"), (0.1, 0.1), ("x", "x"), (3, 3)],
)
def test_the_cell_rule(value: object, written: object) -> None:
    assert tidy_csv.cell(value) == written


def test_a_row_with_a_column_outside_the_table_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="not in the table"):
        tidy_csv.write_rows(tmp_path / "t.csv", ["a"], [{"a": 1, "b": 2}])


def _decision(**values: object) -> dict[str, object]:
    return {column: values.get(column, 1) for column in DECISION_COLUMNS}


def test_the_experiment_writes_a_missing_value_as_an_empty_cell(tmp_path: Path) -> None:
    """It wrote `nan` before, where the export wrote an empty cell."""
    path = tmp_path / "decisions.csv"
    exp.write_decisions([_decision(chosen_value=math.nan, chosen_target=None)], path)
    (row,) = _cells(path)
    assert row["chosen_value"] == "" and row["chosen_target"] == ""
    assert path.read_bytes().endswith(b"\r\n")


def test_a_sweep_cell_and_the_combined_file_keep_the_rule(tmp_path: Path) -> None:
    sweep = sw.Sweep((sw.Axis("p", (1, 2)),), scenarios=1, runs=1, models=("M1",), seed=0)
    (tmp_path / sw.CELLS).mkdir()
    for cell in sweep.cells:
        sw._write_cell(tmp_path, sweep, cell, [_decision(chosen_value=math.nan)])
    rows = _cells(sw.combine(tmp_path, sweep))
    assert [row["p"] for row in rows] == ["1", "2"]
    assert {row["chosen_value"] for row in rows} == {""}
    assert b"\r\n" in (tmp_path / "decisions.csv").read_bytes()
    assert b"\n" not in (tmp_path / "decisions.csv").read_bytes().replace(b"\r\n", b"")


def test_the_equivalence_reference_round_trips(tmp_path: Path) -> None:
    rows = [
        {
            "model": "M1",
            "trial_id": "t1",
            "difficulty": "easy",
            "correct": True,
            "decision_time_s": 61.123456789,
            "timed_out": False,
        }
    ]
    eq.write_reference(rows, tmp_path / "reference.csv")
    assert eq.read_reference(tmp_path / "reference.csv") == rows
