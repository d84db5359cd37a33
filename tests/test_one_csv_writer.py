"""Every CSV of hcss goes through hcss.tidy_csv: no other module writes one, and frames keep the rule."""

from __future__ import annotations

import ast
import csv
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import hcss
from hcss.analysis.tables import Table
from hcss.analysis.tables import write_paper_table as write_analysis_table
from hcss.tidy_csv import write_frame

PACKAGE = Path(hcss.__file__).parent
WRITER = PACKAGE / "tidy_csv.py"


def csv_writes(source: str) -> list[str]:
    """Each CSV write in `source` other than through hcss.tidy_csv: a pandas `to_csv`
    call, or the csv module's `writer`/`DictWriter` (called on the module or imported)."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom) and node.module == "csv":
            found += [
                f"line {node.lineno}: from csv import {alias.name}"
                for alias in node.names
                if alias.name in ("writer", "DictWriter")
            ]
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute):
            attribute = node.func
            on_csv = isinstance(attribute.value, ast.Name) and attribute.value.id == "csv"
            if attribute.attr == "to_csv" or (
                on_csv and attribute.attr in ("writer", "DictWriter")
            ):
                found.append(f"line {node.lineno}: {ast.unparse(node)[:60]}")
    return found


def test_no_module_of_hcss_writes_a_csv_but_the_one_writer() -> None:
    """Four pandas to_csv calls in the analysis (five calls) and fit_study's csv.writer
    wrote `True` with LF line ends before."""
    writes = {
        str(path.relative_to(PACKAGE)): csv_writes(path.read_text(encoding="utf-8"))
        for path in sorted(PACKAGE.rglob("*.py"))
        if path != WRITER
    }
    assert {path: found for path, found in writes.items() if found} == {}


@pytest.mark.parametrize(
    "planted",
    [
        "frame.to_csv(path, index=False)",
        "import csv\ncsv.writer(handle).writerow(row)",
        "import csv\nw = csv.DictWriter(handle, fieldnames=names)",
        "from csv import writer\nwriter(handle)",
    ],
)
def test_the_check_finds_a_planted_csv_write(planted: str) -> None:
    assert csv_writes(planted)


def test_a_frame_is_written_with_the_cell_rule(tmp_path: Path) -> None:
    """pandas' to_csv wrote True, NaN as an empty cell but pd.NA too, and LF line ends."""
    frame = pd.DataFrame(
        {
            "flag": [True, False, True],
            "maybe": pd.array([True, None, False], dtype="boolean"),
            "count": pd.array([1, None, 3], dtype="Int64"),
            "value": [0.1, math.nan, np.float64(1e-7)],
            "name": ["a", None, 'say "hi", then go'],
        }
    )
    path = tmp_path / "frame.csv"
    write_frame(path, frame)
    content = path.read_bytes()
    assert content.count(b"\r\n") == 4 and b"\n" not in content.replace(b"\r\n", b"")
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.reader(handle))
    assert rows == [
        ["flag", "maybe", "count", "value", "name"],
        ["true", "true", "1", "0.1", "a"],
        ["false", "", "", "", ""],
        ["true", "false", "3", "1e-07", 'say "hi", then go'],
    ]
    back = pd.read_csv(path)
    assert back["flag"].tolist() == [True, False, True]
    assert back["value"].tolist()[::2] == [0.1, 1e-7]


def test_a_frame_naming_a_column_twice_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="twice"):
        write_frame(tmp_path / "t.csv", pd.DataFrame([[1, 2]], columns=["a", "a"]))


def test_an_analysis_table_is_written_by_the_one_writer(tmp_path: Path) -> None:
    """A table with a contract (hcss.tablespec.analysis; one without is refused), its
    missing mean and SD written as empty cells, never `nan`."""
    frame = pd.DataFrame({"item": ["gender"], "value": ["f"], "n": [2], "mean": [math.nan]})
    table = Table("demographics", "a table", ("item",), (("gender",),), frame.assign(sd=None))
    csv_path = next(p for p in write_analysis_table(table, tmp_path) if p.suffix == ".csv")
    assert csv_path.read_bytes() == b"item,value,n,mean,sd\r\ngender,f,2,,\r\n"


def test_the_calibration_trials_are_written_by_the_one_writer(tmp_path: Path) -> None:
    """fit_study wrote trials.csv with a csv.writer and a column list of its own (the same
    bytes); the columns are now CALIBRATION_TRIALS' with the parameters and measures."""
    import optuna

    from hcss.experiments.fit_study import SEARCH_SPACE, write_trials
    from hcss.tablespec import CALIBRATION_TRIALS

    study = optuna.create_study()
    rate = optuna.distributions.FloatDistribution(1.0, 3.5, log=True)
    for number, value in enumerate((2.0, 1.5)):
        study.add_trial(
            optuna.trial.create_trial(
                params={"message_rate": value},
                distributions={"message_rate": rate},
                value=10.0 - number,
                user_attrs={"met": 3 + number, "m2_time_cost": math.nan},
            )
        )
    path = tmp_path / "trials.csv"
    write_trials(study, path)
    content = path.read_bytes()
    assert b"\n" not in content.replace(b"\r\n", b"")
    with path.open(newline="", encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    assert tuple(rows[0]) == CALIBRATION_TRIALS.expand(
        parameter=list(SEARCH_SPACE), measure=["m2_time_cost", "met"]
    )
    assert [(r["trial"], r["message_rate"], r["loss"], r["met"]) for r in rows] == [
        ("0", "2.0", "10.0", "3"),
        ("1", "1.5", "9.0", "4"),
    ]
    assert {r["discovery"] for r in rows} == {""} and {r["m2_time_cost"] for r in rows} == {""}
