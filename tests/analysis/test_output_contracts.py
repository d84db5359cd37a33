"""The analysis's own tables keep their contracts (hcss.tablespec.analysis) when written.

Every table `hcss analyze`, a sweep's analysis and the experiment's summary
write is checked against its spec before a file is opened: a column the spec
does not name, a missing column the spec needs, or a cell of another type is
refused with the table, column and row named, and nothing is written.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis import report, rscript
from hcss.analysis.report import run_analysis
from hcss.analysis.rscript import write_r_script
from hcss.analysis.sweeps import SweepInputError, load_sweep
from hcss.analysis.tables import Table, write_checked, write_paper_table
from hcss.tablespec import TableSpec
from hcss.tablespec.analysis import (
    ANALYSIS_TABLES,
    MEASURES,
    NO_ROWS,
    REPORT_TABLES,
    SWEEP_CELLS,
    analysis_table,
)
from hcss.tablespec.frames import ContractError
from tests.support.synthetic import decision_row, simulation_decisions
from tests.support.synthetic import write_table as write_csv

#: A cell of each type that keeps the contract.
GOOD = {"str": "a", "int": 1, "float": 0.5, "bool": True, "any": 2}
#: A cell of another type, and how the refusal names it.
PLANTED = {
    "int": ("x", "expected a whole number"),
    "float": ("soon", "expected a number"),
    "str": (5, "expected text"),
}


def _written_name(spec: TableSpec) -> str:
    """The file name a table of `spec` is written under (a family's: one member)."""
    return spec.name.replace("<measure>", "success_rate").replace("<family>", "performance")


def _frame(spec: TableSpec) -> pd.DataFrame:
    """Two rows that keep `spec`; a pattern column stands for one column, `quorum_k`."""
    row = {
        ("quorum_k" if column.pattern else column.name): GOOD[column.dtype]
        for column in spec.columns
    }
    return pd.DataFrame([row, row])


def _write(spec: TableSpec, frame: pd.DataFrame, directory: Path) -> Path:
    """Through the writer the analysis uses for the table: write_paper_table for the report's."""
    name = _written_name(spec)
    if spec in REPORT_TABLES:
        write_paper_table(Table(name, "caption", ("a",), (("1",),), frame), directory)
    else:
        write_checked(directory / f"{name}.csv", frame, spec, name)
    return directory / f"{name}.csv"


def _ids(spec: TableSpec) -> str:
    return spec.name


@pytest.mark.parametrize("spec", ANALYSIS_TABLES, ids=_ids)
def test_a_frame_that_keeps_the_contract_is_written_in_the_contract_order(
    spec: TableSpec, tmp_path: Path
) -> None:
    frame = _frame(spec)
    path = _write(spec, frame.iloc[:, ::-1], tmp_path)  # its columns reversed
    header = path.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header == list(frame.columns)


#: The tables without a pattern column (a pattern column takes any other column: its type
#: is checked, test_a_pattern_column_checks_its_columns_with_its_type).
FIXED = tuple(spec for spec in ANALYSIS_TABLES if not any(c.pattern for c in spec.columns))


@pytest.mark.parametrize("spec", FIXED, ids=_ids)
def test_a_column_the_contract_does_not_name_is_refused_and_nothing_written(
    spec: TableSpec, tmp_path: Path
) -> None:
    frame = _frame(spec).assign(planted=1.0)
    name = _written_name(spec)
    with pytest.raises(ContractError, match=f"table '{name}' has column 'planted', which its"):
        _write(spec, frame, tmp_path)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("spec", ANALYSIS_TABLES, ids=_ids)
def test_a_cell_of_the_wrong_type_is_refused_with_its_column_and_row(
    spec: TableSpec, tmp_path: Path
) -> None:
    frame = _frame(spec)
    numbers = [c for c in spec.columns if c.dtype in ("int", "float")]
    column = numbers[0] if numbers else spec.columns[0]  # a table of text: its first column
    name = "quorum_k" if column.pattern else column.name
    value, words = PLANTED[column.dtype]
    frame[name] = frame[name].astype(object)
    frame.loc[1, name] = value
    with pytest.raises(
        ContractError,
        match=f"table '{_written_name(spec)}' breaks its contract: column '{name}' holds "
        f"'{value}' in row 3, {words}",
    ):
        _write(spec, frame, tmp_path)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("spec", ANALYSIS_TABLES, ids=_ids)
def test_a_missing_column_the_contract_needs_is_refused(spec: TableSpec, tmp_path: Path) -> None:
    needed = next(c.name for c in spec.columns if not c.nullable and not c.pattern)
    with pytest.raises(ContractError, match=f"lacks column '{needed}', which its contract needs"):
        _write(spec, _frame(spec).drop(columns=needed), tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_text_column_holding_a_number_is_refused(tmp_path: Path) -> None:
    frame = _frame(MEASURES).assign(unit=[7, 8])
    with pytest.raises(ContractError, match="column 'unit' holds '7' in row 2, expected text"):
        write_checked(tmp_path / "measures.csv", frame, MEASURES)


def test_a_pattern_column_checks_its_columns_with_its_type(tmp_path: Path) -> None:
    """The counterbalancing table's columns per status are counts."""
    spec = analysis_table("counterbalancing")
    frame = pd.DataFrame({"cell": ["1"], "model_order": ["M1,M2,M3"], "completed": ["many"]})
    with pytest.raises(ContractError, match="column 'completed' holds 'many' in row 2"):
        _write(spec, frame, tmp_path)
    _write(spec, frame.assign(completed=3, aborted=0), tmp_path)


def test_a_report_table_without_a_contract_is_refused(tmp_path: Path) -> None:
    table = Table("planted_table", "caption", ("a",), (("1",),), pd.DataFrame({"a": [1]}))
    with pytest.raises(LookupError, match="'planted_table' that no spec in hcss.tablespec"):
        write_paper_table(table, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_a_family_name_finds_its_spec_and_an_empty_table_is_a_note() -> None:
    assert analysis_table("descriptive_nasa_tlx_overall").name == "descriptive_<measure>"
    assert analysis_table("pmatrix_sa_probes").name == "pmatrix_<family>"
    assert analysis_table("spearman_mrt").name == "spearman_mrt"
    assert NO_ROWS.names == ("note",)


def test_the_report_writes_measures_through_its_contract(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """measures.csv: a measure computed into a column the contract does not name is refused."""
    write_csv(simulation_decisions(scenarios=3, runs=1), tmp_path / "sim" / "decisions.csv")
    measures = report.all_measures
    monkeypatch.setattr(report, "all_measures", lambda tables: measures(tables).assign(planted=1.0))
    with pytest.raises(ContractError, match="table 'measures' has column 'planted'"):
        run_analysis([tmp_path / "sim" / "decisions.csv"], tmp_path / "out", progress=False)
    assert not (tmp_path / "out" / "measures.csv").exists()


def test_the_r_script_inputs_are_written_through_their_contracts(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    human = pd.DataFrame(
        {
            "participant": ["P1"],
            "trial_id": ["1"],
            "model": ["M1"],
            "difficulty": ["easy"],
            "correct": [True],
            "decision_time_s": [30.0],
            "position": ["first"],
        }
    )
    monkeypatch.setattr(rscript, "human_decisions", lambda decisions, participants: human)
    with pytest.raises(
        ContractError, match="table 'model_decisions' breaks its contract: column 'position'"
    ):
        write_r_script(tmp_path, pd.DataFrame(), pd.DataFrame())
    scores = pd.DataFrame(
        {"participant": ["P1"], "instrument": ["mrt"], "scale": ["total"], "score": ["high"]}
    )
    monkeypatch.setattr(rscript, "human_decisions", lambda decisions, participants: human[:0])
    with pytest.raises(ContractError, match="table 'mrt_scores' breaks its contract"):
        write_r_script(tmp_path, pd.DataFrame(), pd.DataFrame(), scores)
    assert not (tmp_path / "model_decisions.csv").exists()
    human["position"] = 1
    monkeypatch.setattr(rscript, "human_decisions", lambda decisions, participants: human)
    written = write_r_script(tmp_path, pd.DataFrame(), pd.DataFrame())
    assert [path.name for path in written] == ["analysis.R", "model_decisions.csv"]


def test_a_sweep_cells_table_keeps_its_contract_with_a_column_per_parameter(
    tmp_path: Path,
) -> None:
    frame = _frame(SWEEP_CELLS).rename(columns={"quorum_k": "message_rate"})
    write_checked(tmp_path / "sweep_cells.csv", frame.assign(quorum_k=10), SWEEP_CELLS)
    header = (tmp_path / "sweep_cells.csv").read_text(encoding="utf-8").splitlines()[0]
    assert header.startswith("message_rate,quorum_k,model,trials,")


def test_a_sweep_is_read_through_its_decisions_contract(tmp_path: Path) -> None:
    """A decision time in words passed the loader (the cell table then failed on it); now the
    loader names it."""
    (tmp_path / "sweep.json").write_text('{"parameters": ["quorum_k"]}', encoding="utf-8")
    rows = [
        decision_row() | {"quorum_k": 10},
        decision_row(decision_time_s="soon") | {"quorum_k": 10},
    ]
    write_csv(pd.DataFrame(rows), tmp_path / "decisions.csv")
    with pytest.raises(
        SweepInputError,
        match="decisions.csv: column 'decision_time_s' holds 'soon' in row 3, expected a number",
    ):
        load_sweep(tmp_path)
    write_csv(pd.DataFrame(rows[:1]), tmp_path / "decisions.csv")
    names, decisions = load_sweep(tmp_path)
    assert names == ["quorum_k"] and len(decisions) == 1
