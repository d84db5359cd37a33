"""The table contracts: one place for each table's columns, the dictionary rendered from it."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.load import AnalysisInputError, load_inputs
from hcss.platform.export.tables import TABLES
from hcss.platform.export.writer import DICTIONARY
from hcss.simulation import MODELS
from hcss.tablespec import DECISIONS, EXPORT_TABLES, SWEEP_DECISIONS, Column, TableSpec
from hcss.tablespec import export as export_spec
from hcss.tablespec.analysis import ANALYSIS_TABLES
from hcss.tablespec.dictionary import render
from hcss.tablespec.frames import ContractError, check
from hcss.tidy_csv import write_rows


def test_the_committed_dictionary_is_the_one_rendered_from_the_specs() -> None:
    """Edit a spec and not the dictionary (or the reverse) and this fails; the fix is
    `python -m hcss.tablespec.dictionary hcss/platform/export/data-dictionary.md`."""
    assert DICTIONARY.read_text(encoding="utf-8") == render()


def test_every_column_of_every_table_is_in_the_dictionary_with_its_type_and_rule() -> None:
    listed = {}
    for line in render().splitlines():
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if line.startswith("| ") and len(cells) == 4:
            for name in cells[0].split(", "):
                listed.setdefault(name, set()).add((cells[1], cells[2]))
    for spec in EXPORT_TABLES.values():
        for column in spec.columns:
            missing = "allowed" if column.nullable else "never"
            assert (column.dtype, missing) in listed[column.name], (spec.name, column)


def test_every_table_the_analysis_writes_is_in_the_dictionary() -> None:
    """Each with its heading and every column with its type and rule."""
    text = render()
    for spec in ANALYSIS_TABLES:
        section = text.split(f"### {spec.title}\n", 1)[1].split("\n### ", 1)[0]
        for column in spec.columns:
            name = column.name.replace("<", "&lt;").replace(">", "&gt;")
            missing = "allowed" if column.nullable else "never"
            assert any(
                line.startswith("| ")
                and name in line.split(" | ")[0]
                and f" | {column.dtype} | {missing} | " in line
                for line in section.splitlines()
            ), (spec.name, column.name)


def test_the_export_reads_its_tables_from_the_specs() -> None:
    assert list(TABLES) == list(EXPORT_TABLES)
    assert all(TABLES[name] == spec.typed for name, spec in EXPORT_TABLES.items())


def test_the_participants_per_model_columns_name_the_models_of_the_model() -> None:
    assert export_spec.MODELS == MODELS


def test_a_pattern_column_expands_to_the_names_given_at_write_time() -> None:
    names = SWEEP_DECISIONS.expand(parameter=("message_rate", "quorum_k"))
    assert names == ("message_rate", "quorum_k", *DECISIONS.names)
    with pytest.raises(ValueError, match="expands"):
        SWEEP_DECISIONS.expand()
    with pytest.raises(ValueError, match="repeats"):
        SWEEP_DECISIONS.expand(parameter=("model",))


def test_a_spec_refuses_a_repeated_column_and_an_unknown_type() -> None:
    with pytest.raises(ValueError, match="twice"):
        TableSpec("t", "t", "", (Column("a", "int", ""), Column("a", "str", "")))
    with pytest.raises(ValueError, match="unknown type"):
        Column("a", "integer", "")


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"run": [0, 1.5]}, "column 'run' holds '1.5' in row 3, expected a whole number"),
        ({"run": [0, "x"]}, "column 'run' holds 'x' in row 3, expected a whole number"),
        ({"end_s": [1.0, "soon"]}, "column 'end_s' holds 'soon' in row 3, expected a number"),
        ({"run": [0, None]}, "column 'run' has an empty cell in row 3"),
    ],
)
def test_a_frame_that_breaks_the_contract_is_named_by_column_value_and_row(
    values: dict[str, list[object]], message: str
) -> None:
    frame = pd.DataFrame(values)
    with pytest.raises(ContractError, match=message):
        check(frame, DECISIONS, list(values))


def test_a_frame_without_a_contract_column_is_refused_and_one_that_keeps_it_passes() -> None:
    with pytest.raises(ContractError, match="lacks column 'seed'"):
        check(pd.DataFrame({"run": [0]}), DECISIONS, ["run", "seed"])
    frame = pd.DataFrame({"run": [0, 1], "chosen_target": [3, None], "correct": [True, False]})
    check(frame, DECISIONS, ["run", "chosen_target", "correct"])
    assert frame["run"].tolist() == [0, 1]  # the check coerces a copy


def _decision(**values: object) -> dict[str, object]:
    """One decisions row that keeps the contract, with `values` changed."""
    row: dict[str, object] = {name: 1 for name in DECISIONS.names}
    row.update(
        source="simulation",
        model="M1",
        participant=None,
        trial_id="t",
        scenario_id="s",
        first_section="easy",
        section_kind="easy",
        collective="I",
        difficulty="easy",
        timed_out=False,
        correct=True,
        start_s=0,  # end_s − start_s = decision_time_s, as the loader checks
    )
    row.update(values)
    return row


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"run": "first"}, "column 'run' holds 'first' in row 3, expected a whole number"),
        ({"decision_index": 1.5}, "column 'decision_index' holds '1.5' in row 3"),
        ({"collective": None}, "column 'collective' has an empty cell in row 3"),
        ({"trial_id": None}, "column 'trial_id' has an empty cell in row 3"),
    ],
)
def test_the_analysis_refuses_a_decisions_table_that_breaks_the_contract(
    tmp_path: Path, values: dict[str, object], message: str
) -> None:
    """These loaded before: a run named in words, a half decision, a decision of no collective."""
    path = tmp_path / "decisions.csv"
    write_rows(path, DECISIONS.names, [_decision(), _decision(**values)])
    with pytest.raises(AnalysisInputError, match=f"{path}: {message}"):
        load_inputs([path])
    write_rows(path, DECISIONS.names, [_decision(), _decision(decision_index=2)])
    assert len(load_inputs([path]).decisions) == 2


def test_the_analysis_refuses_an_export_table_that_breaks_the_contract(tmp_path: Path) -> None:
    participants = EXPORT_TABLES["participants"]
    write_rows(tmp_path / "decisions.csv", DECISIONS.names, [_decision()])
    write_rows(
        tmp_path / "participants.csv",
        participants.names,
        [{"participant": "P1", "is_bot": False}, {"participant": None, "is_bot": False}],
    )
    with pytest.raises(AnalysisInputError, match="column 'participant' has an empty cell in row 3"):
        load_inputs([tmp_path])
