"""Inputs that would double a table or move a decision: refused before anything is computed.

Each decision has one key (source, trial, collective, decision index) across
every INPUT; the same file given twice, or a row copied inside one, used to
double the study-unit N (132 → 264) silently. An end time that disagrees with
start + decision time moved a decision into another slot of the study's unit.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from hcss.analysis.load import TIME_TOLERANCE_S, AnalysisInputError, load_inputs
from hcss.cli import main
from tests.support.synthetic import (
    DECISION_COLUMNS,
    decision_row,
    simulation_decisions,
    study_export,
    write_table,
)


def test_the_same_file_twice_is_refused_naming_both_places(tmp_path: Path):
    decisions = simulation_decisions(scenarios=2, runs=1)
    first = write_table(decisions, tmp_path / "a" / "decisions.csv")
    second = write_table(decisions, tmp_path / "b" / "decisions.csv")
    with pytest.raises(AnalysisInputError) as refused:
        load_inputs([first, second])
    message = str(refused.value)
    assert f"{first} row 2" in message and f"{second} row 2" in message
    assert "trial M1-s0-r0, collective I, decision 1" in message
    assert f"{len(decisions)} decisions appear more than once" in message
    assert "--drop-exact-duplicates" in message
    assert len(message.splitlines()) <= 4


def test_a_copied_row_inside_one_file_is_refused(tmp_path: Path):
    decisions = simulation_decisions(scenarios=2, runs=1)
    doubled = pd.concat([decisions, decisions.iloc[[5]]], ignore_index=True)
    path = write_table(doubled, tmp_path / "decisions.csv")
    with pytest.raises(AnalysisInputError, match=r"row 7 and .*decisions.csv row 50"):
        load_inputs([path])


def test_exact_duplicates_are_dropped_with_a_count_when_asked(tmp_path: Path):
    decisions = simulation_decisions(scenarios=2, runs=1)
    doubled = pd.concat([decisions, decisions.iloc[:24]], ignore_index=True)
    path = write_table(doubled, tmp_path / "decisions.csv")
    tables = load_inputs([path], drop_exact_duplicates=True)
    assert len(tables.decisions) == len(decisions)
    assert any("dropped 24 exact duplicate rows" in text for text in tables.warnings)


def test_a_key_given_twice_with_different_values_is_refused_even_when_dropping(tmp_path: Path):
    decisions = simulation_decisions(scenarios=2, runs=1)
    changed = decisions.iloc[[3]].assign(correct=~decisions.iloc[3]["correct"])
    path = write_table(pd.concat([decisions, changed], ignore_index=True), tmp_path / "d.csv")
    with pytest.raises(AnalysisInputError, match="differ in correct"):
        load_inputs([path], drop_exact_duplicates=True)


def test_an_end_time_that_disagrees_with_start_plus_decision_time_is_refused(tmp_path: Path):
    rows = [decision_row(source="simulation", trial_id=f"t{i}") for i in range(3)]
    frame = pd.DataFrame(rows, columns=DECISION_COLUMNS)
    frame.loc[1, "end_s"] = 600.0  # start 0, decision time 60
    path = write_table(frame, tmp_path / "decisions.csv")
    with pytest.raises(AnalysisInputError) as refused:
        load_inputs([path])
    message = str(refused.value)
    assert "row 3: end_s 600 − start_s 0 = 600 s, but decision_time_s is 60" in message
    assert f"{TIME_TOLERANCE_S:g} s" in message


def test_times_within_the_tolerance_pass(tmp_path: Path):
    rows = [decision_row(source="simulation", trial_id=f"t{i}") for i in range(3)]
    frame = pd.DataFrame(rows, columns=DECISION_COLUMNS)
    frame.loc[1, "end_s"] = 60.0 + TIME_TOLERANCE_S / 2
    path = write_table(frame, tmp_path / "decisions.csv")
    assert len(load_inputs([path]).decisions) == 3


def test_a_comma_header_over_semicolon_rows_is_a_short_error(tmp_path: Path):
    """Such a file gave a 114 KB one-line error listing every row."""
    rows = [decision_row(source="simulation", trial_id=f"t{i}") for i in range(300)]
    body = pd.DataFrame(rows, columns=DECISION_COLUMNS).to_csv(sep=";", index=False)
    path = tmp_path / "decisions.csv"
    path.write_text(",".join(DECISION_COLUMNS) + "\n" + "".join(body.splitlines(True)[1:]))
    with pytest.raises(AnalysisInputError) as refused:
        load_inputs([path])
    message = str(refused.value)
    assert len(message) < 400 and len(message.splitlines()) <= 3
    assert "row 2" in message and "semicolons" in message


def test_many_bad_values_are_named_by_the_first_few(tmp_path: Path):
    rows = [decision_row(source=f"robot{i}", trial_id=f"t{i}") for i in range(500)]
    path = write_table(pd.DataFrame(rows, columns=DECISION_COLUMNS), tmp_path / "decisions.csv")
    with pytest.raises(AnalysisInputError) as refused:
        load_inputs([path])
    message = str(refused.value)
    assert len(message) < 400
    assert "'robot0' (row 2)" in message and "and 497 more" in message


def _analyze_in_a_fresh_process(tmp_path: Path, *args: str) -> tuple[str, float]:
    """`hcss analyze` in its own interpreter; prints which heavy libraries it imported."""
    probe = (
        "import sys, runpy\n"
        "from click.testing import CliRunner\n"
        "from hcss.cli import main\n"
        f"result = CliRunner().invoke(main, {['analyze', *args]!r})\n"
        "print(result.exit_code, result.output.strip().replace(chr(10), ' | '))\n"
        "print(sorted(m for m in ('statsmodels', 'matplotlib') if m in sys.modules))\n"
    )
    started = time.perf_counter()
    done = subprocess.run(
        [sys.executable, "-c", probe],
        capture_output=True,
        text=True,
        check=True,
        cwd=tmp_path,
        env={**os.environ, "PYTHONPATH": str(Path(__file__).parents[2])},
    )
    return done.stdout, time.perf_counter() - started


def test_a_refused_input_is_refused_before_the_statistics_are_imported(tmp_path: Path):
    """A 1 GB file was refused after 136 s: every check ran after scipy, statsmodels and
    matplotlib were imported."""
    decisions = simulation_decisions(scenarios=1, runs=1)
    path = write_table(pd.concat([decisions, decisions]), tmp_path / "decisions.csv")
    output, _ = _analyze_in_a_fresh_process(tmp_path, str(path), "--out", "report")
    status, imported = output.splitlines()
    assert status.startswith("1 ") and "appear more than once" in status
    assert imported == "[]"
    assert not (tmp_path / "report").exists()


def test_the_command_drops_exact_duplicates_when_asked(tmp_path: Path):
    decisions = simulation_decisions(scenarios=3, runs=1)
    path = write_table(pd.concat([decisions, decisions.head(4)]), tmp_path / "decisions.csv")
    result = CliRunner().invoke(
        main,
        ["analyze", str(path), "--out", str(tmp_path / "out"), "--quiet"],
    )
    assert result.exit_code == 1 and "appear more than once" in result.output
    result = CliRunner().invoke(
        main,
        [
            "analyze",
            str(path),
            "--out",
            str(tmp_path / "out"),
            "--quiet",
            "--drop-exact-duplicates",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "dropped 4 exact duplicate rows" in result.output
    report = (tmp_path / "out" / "report.html").read_text()
    assert "dropped 4 exact duplicate rows" in report


def test_the_same_export_twice_is_refused_and_dropped_whole_when_asked(tmp_path: Path):
    """With --drop-exact-duplicates the decisions were single but questionnaires doubled."""
    export = study_export(tmp_path / "export", participants=4)
    copy = tmp_path / "copy"
    shutil.copytree(export, copy)
    with pytest.raises(AnalysisInputError, match="appear more than once"):
        load_inputs([export, copy])
    once = load_inputs([export])
    both = load_inputs([export, copy], drop_exact_duplicates=True)
    for table in ("decisions", "scores", "probes", "questionnaire_items", "participants"):
        assert len(getattr(both, table)) == len(getattr(once, table)), table


def test_a_participant_in_two_exports_is_refused(tmp_path: Path):
    export = study_export(tmp_path / "export", participants=4)
    other = study_export(tmp_path / "other", participants=4, seed=3)
    decisions = pd.read_csv(other / "decisions.csv")
    decisions["trial_id"] = "other-" + decisions["trial_id"].astype(str)
    decisions.to_csv(other / "decisions.csv", index=False)
    with pytest.raises(AnalysisInputError, match="participants appear more than once.*P00 in"):
        load_inputs([export, other])
