"""Loading: tagging by source and model, and clear errors for bad input."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.load import AnalysisInputError, load_inputs, parse_bool
from tests.analysis.synthetic import (
    DECISION_COLUMNS,
    decision_row,
    simulation_decisions,
    write_table,
)


def test_groups_are_tagged_by_source_and_model(tmp_path: Path):
    rows = [
        decision_row(source="simulation", model="M1", trial_id="a"),
        decision_row(source="simulation", model="M2", trial_id="b"),
        decision_row(source="study", model="M3", participant="P1", trial_id="c"),
    ]
    write_table(pd.DataFrame(rows, columns=DECISION_COLUMNS), tmp_path / "decisions.csv")
    tables = load_inputs([tmp_path / "decisions.csv"], include_pilot=True)
    assert list(tables.decisions["group"]) == ["M1SIM", "M2SIM", "M3"]
    assert tables.groups == ["M1SIM", "M2SIM", "M3"]
    assert tables.decisions["correct"].dtype == "boolean"
    assert tables.requests.empty and "kind" in tables.requests.columns


def test_directory_and_file_inputs_combine(tmp_path: Path):
    decisions = simulation_decisions(scenarios=2, runs=2)
    write_table(decisions, tmp_path / "run" / "decisions.csv")
    write_table(decisions.head(5), tmp_path / "extra.csv")
    tables = load_inputs([tmp_path / "run", tmp_path / "extra.csv"])
    assert len(tables.decisions) == len(decisions) + 5


@pytest.mark.parametrize(
    ("content", "message"),
    [
        ("", "empty"),
        (",".join(DECISION_COLUMNS) + "\n", "no rows"),
        ("source,model\nsimulation,M1\n", "lacks column"),
    ],
)
def test_bad_decisions_tables_are_explained(tmp_path: Path, content: str, message: str):
    path = tmp_path / "decisions.csv"
    path.write_text(content)
    with pytest.raises(AnalysisInputError, match=message):
        load_inputs([path])


def test_unknown_model_and_source_are_refused(tmp_path: Path):
    path = tmp_path / "decisions.csv"
    write_table(pd.DataFrame([decision_row(source="simulation", model="M9")]), path)
    with pytest.raises(AnalysisInputError, match="unknown model"):
        load_inputs([path])
    write_table(pd.DataFrame([decision_row(source="robot")]), path)
    with pytest.raises(AnalysisInputError, match="source must be"):
        load_inputs([path])


def test_directory_without_decisions_and_missing_path(tmp_path: Path):
    with pytest.raises(AnalysisInputError, match="no export tables"):
        load_inputs([tmp_path])
    with pytest.raises(AnalysisInputError, match="no such file"):
        load_inputs([tmp_path / "nowhere"])


def test_study_decisions_need_participants_to_exclude_bots(tmp_path: Path):
    write_table(
        pd.DataFrame([decision_row(source="study", participant="P1")]), tmp_path / "decisions.csv"
    )
    with pytest.raises(AnalysisInputError, match="participants.csv"):
        load_inputs([tmp_path])
    assert len(load_inputs([tmp_path], include_pilot=True).decisions) == 1


def test_only_flagged_participants_left_is_an_error(tmp_path: Path):
    write_table(
        pd.DataFrame([decision_row(source="study", participant="B1")]), tmp_path / "decisions.csv"
    )
    write_table(
        pd.DataFrame([{"participant": "B1", "is_pilot": False, "is_bot": False, "is_demo": True}]),
        tmp_path / "participants.csv",
    )
    with pytest.raises(AnalysisInputError, match="--include-pilot"):
        load_inputs([tmp_path])


def test_parse_bool_reads_dictionary_booleans_and_refuses_others():
    parsed = parse_bool(pd.Series(["true", "false", None, "True"], name="correct"))
    assert parsed.tolist()[:2] == [True, False]
    assert pd.isna(parsed[2]) and parsed[3]
    with pytest.raises(AnalysisInputError, match="expected true or false"):
        parse_bool(pd.Series(["maybe"], name="correct"))
