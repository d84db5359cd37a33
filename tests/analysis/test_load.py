"""Loading: tagging by source and model, and clear errors for bad input."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.load import AnalysisInputError, load_inputs, parse_bool
from tests.support.synthetic import (
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
    extra = decisions.head(5).assign(trial_id=lambda frame: "extra-" + frame["trial_id"])
    write_table(extra, tmp_path / "extra.csv")
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


def test_parquet_file_folder_and_zip_give_the_same_decisions(tmp_path: Path):
    import zipfile

    decisions = simulation_decisions(scenarios=2, runs=1)
    csv_path = write_table(decisions, tmp_path / "csv" / "decisions.csv")
    (tmp_path / "parquet").mkdir()
    decisions.to_parquet(tmp_path / "parquet" / "decisions.parquet")  # real booleans
    with zipfile.ZipFile(tmp_path / "export.zip", "w") as archive:
        archive.write(csv_path, "hcss-export-x/decisions.csv")
        archive.writestr("hcss-export-x/training/decisions.csv", "not,read\n")
    expected = load_inputs([csv_path]).decisions
    for source in (
        tmp_path / "parquet" / "decisions.parquet",
        tmp_path / "parquet",
        tmp_path / "export.zip",
    ):
        loaded = load_inputs([source]).decisions
        assert loaded["correct"].tolist() == expected["correct"].tolist(), source
        assert loaded["group"].tolist() == expected["group"].tolist(), source
        assert loaded["decision_time_s"].tolist() == expected["decision_time_s"].tolist()
        assert set(loaded["input"]) == {str(source)}


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        ("broken.zip", b"PK\x03\x04 not really a zip", "not a CSV, Parquet or zip"),
        ("notes.txt", b"hello", "not a CSV, Parquet or zip"),
        ("decisions.parquet", b"PAR1\x00garbage", "cannot read the decisions table"),
        ("decisions.csv", b"source,model\x00\nstudy,M1\n", "lacks column(s)"),
    ],
)
def test_hostile_files_are_clear_errors(tmp_path: Path, name: str, content: bytes, message: str):
    (tmp_path / name).write_bytes(content)
    with pytest.raises(AnalysisInputError, match=re_escape(message)):
        load_inputs([tmp_path / name])


def test_zip_with_two_exports_or_no_tables_is_refused(tmp_path: Path):
    import zipfile

    with zipfile.ZipFile(tmp_path / "two.zip", "w") as archive:
        archive.writestr("a/decisions.csv", "x\n")
        archive.writestr("b/decisions.csv", "x\n")
    with pytest.raises(AnalysisInputError, match="several exports"):
        load_inputs([tmp_path / "two.zip"])
    with zipfile.ZipFile(tmp_path / "empty.zip", "w") as archive:
        archive.writestr("readme.txt", "nothing")
    with pytest.raises(AnalysisInputError, match="no export tables"):
        load_inputs([tmp_path / "empty.zip"])


def test_an_input_that_contributes_nothing_is_named(tmp_path: Path):
    write_table(simulation_decisions(scenarios=2, runs=1), tmp_path / "sim.csv")
    write_table(simulation_decisions(scenarios=1, runs=1).iloc[:0], tmp_path / "empty.csv")
    tables = load_inputs([tmp_path / "sim.csv", tmp_path / "empty.csv"])
    assert tables.warnings == (
        f"{tmp_path / 'empty.csv'} contributes nothing: its tables have no rows",
    )
    assert [summary.rows for summary in tables.inputs] == [48, 0]


def re_escape(text: str) -> str:
    import re

    return re.escape(text)


@pytest.mark.parametrize(
    ("time", "message"),
    [
        ("soon", "'decision_time_s' holds 'soon' in row 3"),
        ("inf", "'decision_time_s' holds 'inf' in row 3"),
        ("-4.5", "'decision_time_s' holds '-4.5' in row 3"),
    ],
)
def test_text_infinite_or_negative_times_are_refused(tmp_path: Path, time: str, message: str):
    """A time column with text used to end in a traceback; infinity and negatives passed."""
    rows = [decision_row(source="simulation", trial_id=f"t{i}") for i in range(3)]
    frame = pd.DataFrame(rows, columns=DECISION_COLUMNS).astype({"decision_time_s": object})
    frame.loc[1, "decision_time_s"] = time
    write_table(frame, tmp_path / "decisions.csv")
    with pytest.raises(AnalysisInputError, match=re_escape(message)):
        load_inputs([tmp_path / "decisions.csv"])


def _zip_with_one_export(path: Path, decisions: pd.DataFrame) -> bytes:
    import zipfile

    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("hcss-export-x/decisions.csv", decisions.to_csv(index=False))
    return path.read_bytes()


def _patch_central_directory(content: bytes, offset: int, value: int) -> bytes:
    """Set a 2-byte field of the (only) central-directory entry."""
    start = content.index(b"PK\x01\x02") + offset
    return content[:start] + value.to_bytes(2, "little") + content[start + 2 :]


@pytest.mark.parametrize("damage", ["corrupt", "compression", "encrypted"])
def test_damaged_zip_members_are_clear_errors(tmp_path: Path, damage: str):
    """Each of these ended in a zlib.error, NotImplementedError or RuntimeError traceback."""
    decisions = simulation_decisions(scenarios=2, runs=1)
    content = _zip_with_one_export(tmp_path / "export.zip", decisions)
    if damage == "corrupt":
        start = content.index(b"decisions.csv") + len(b"decisions.csv") + 20
        content = content[:start] + bytes(40) + content[start + 40 :]
    elif damage == "compression":
        content = _patch_central_directory(content, 10, 99)  # method 99: AES, unsupported
    else:
        content = _patch_central_directory(content, 8, 0x1)  # flag bit 0: encrypted
    (tmp_path / "export.zip").write_bytes(content)
    with pytest.raises(AnalysisInputError, match="export.zip: cannot read it"):
        load_inputs([tmp_path / "export.zip"])


@pytest.mark.parametrize(
    ("column", "value", "message"),
    [
        # 1e300 s was accepted and printed as a 300-digit mean with SD "(inf)"
        ("decision_time_s", "1e300", "holds '1e+300' in row 3, expected a number from 0 to 3600"),
        ("decision_time_s", "3600.5", "holds '3600.5' in row 3, expected a number from 0 to 3600"),
        ("n_requests", "2.5", "holds '2.5' in row 3, expected a whole number from 0 to 100000"),
    ],
)
def test_values_outside_a_columns_plausible_range_are_refused(
    tmp_path: Path, column: str, value: str, message: str
):
    rows = [decision_row(source="simulation", trial_id=f"t{i}") for i in range(3)]
    frame = pd.DataFrame(rows, columns=DECISION_COLUMNS).astype({column: object})
    frame.loc[1, column] = value
    write_table(frame, tmp_path / "decisions.csv")
    with pytest.raises(AnalysisInputError, match=re_escape(message)):
        load_inputs([tmp_path / "decisions.csv"])


def test_a_semicolon_file_gets_a_delimiter_hint(tmp_path: Path):
    """A semicolon CSV reported all 17 columns missing and nothing else."""
    rows = [decision_row(source="simulation", trial_id="t1")]
    path = tmp_path / "decisions.csv"
    pd.DataFrame(rows, columns=DECISION_COLUMNS).to_csv(path, sep=";", index=False)
    with pytest.raises(AnalysisInputError, match="one column separated by semicolons"):
        load_inputs([path])


def test_a_file_without_line_breaks_is_refused_in_bounded_memory(tmp_path: Path):
    """A 50 MB file with no line break ran 15 min past 2 GB before it was stopped."""
    import time
    import tracemalloc

    path = tmp_path / "decisions.csv"
    path.write_bytes(b"source," * (8 * 1024 * 1024))  # 56 MB, one line
    tracemalloc.start()
    started = time.perf_counter()
    try:
        with pytest.raises(AnalysisInputError, match="line 1 of the decisions table is longer"):
            load_inputs([path])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 16 * 1024 * 1024 and time.perf_counter() - started < 5


def test_a_table_larger_than_an_export_can_be_is_refused_unread(tmp_path: Path, monkeypatch):
    from hcss.analysis import sources

    path = tmp_path / "decisions.csv"
    path.write_bytes(b"source\n" + b"study\n" * 200)
    monkeypatch.setattr(sources, "MAX_MEMBER_BYTES", 1024)
    with pytest.raises(AnalysisInputError, match="larger than a study export can be"):
        load_inputs([path])
