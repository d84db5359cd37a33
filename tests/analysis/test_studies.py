"""`hcss analyze` keeps study files apart: one with --study, several only with --pool-studies."""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from hcss.analysis.cli import analyze
from hcss.analysis.load import AnalysisInputError, load_inputs
from tests.support.synthetic import study_export

ORIGINAL, DEMO = "a" * 64, "b" * 64
DEMO_CODES = {"P04", "P05"}
UNUSED = {"U01", "U02", "U03"}


@pytest.fixture(scope="module")
def mixed_export(tmp_path_factory) -> Path:
    """A study export whose P04 and P05 ran the demo study file, the rest the original."""
    directory = study_export(tmp_path_factory.mktemp("mixed") / "export")
    path = directory / "participants.csv"
    participants = pd.read_csv(path)
    demo = participants["participant"].isin(DEMO_CODES)
    participants["study"] = participants["study"].where(~demo, "demo")
    participants["study_digest"] = [DEMO if d else ORIGINAL for d in demo]
    # Three links created for the original study and never opened: no study file, no cell.
    unused = participants.iloc[:3].copy()
    unused["participant"] = sorted(UNUSED)
    unused[["study_digest", "cell", "model_order"]] = None
    unused["status"] = "not_started"
    unused[["is_bot", "is_pilot", "is_demo"]] = False
    pd.concat([participants, unused]).to_csv(path, index=False)
    return directory


def test_two_study_files_are_refused_and_named(mixed_export: Path, tmp_path: Path) -> None:
    """Two files; the links never opened are not a third (a study file "not exported")."""
    result = CliRunner().invoke(analyze, [str(mixed_export), "--out", str(tmp_path / "r")])
    assert result.exit_code == 1
    assert "2 different study files" in result.output
    assert "original (file aaaaaaaaaaaa…): 4 participants" in result.output
    assert "demo (file bbbbbbbbbbbb…): 2 participants" in result.output
    assert "--study NAME" in result.output and "--pool-studies" in result.output
    assert not (tmp_path / "r").exists()


def test_one_study_is_analysed_and_named_in_the_report(mixed_export: Path, tmp_path: Path) -> None:
    arguments = [str(mixed_export), "--out", str(tmp_path / "r"), "--study", "original", "--quiet"]
    result = CliRunner().invoke(analyze, arguments)
    assert result.exit_code == 0, result.output
    report = (tmp_path / "r" / "report.html").read_text(encoding="utf-8")
    assert (
        "the file its participants ran): original (file aaaaaaaaaaaa…): 4 participants." in report
    )
    assert "3 participant links were never opened (not started)" in report
    sample = pd.read_csv(tmp_path / "r" / "tables" / "sample.csv")
    enrolled = sample.loc[sample["row"] == "Enrolled (real participants)", "n"].item()
    assert enrolled == 4  # P00-P03: the pilot and the bot are not real, the links not opened
    measures = pd.read_csv(tmp_path / "r" / "measures.csv")
    assert not DEMO_CODES & set(measures["participant"].dropna().astype(str))
    nothing = CliRunner().invoke(analyze, [*arguments[:3], "--study", "pilot-2"])
    assert nothing.exit_code == 1 and "no participant of study 'pilot-2'" in nothing.output
    assert "studies there: demo, original" in nothing.output


def test_pooling_is_allowed_when_asked(mixed_export: Path) -> None:
    with pytest.raises(AnalysisInputError, match="different study files"):
        load_inputs([mixed_export])
    pooled = load_inputs([mixed_export], pool_studies=True)
    assert [(s.name, s.participants) for s in pooled.studies] == [("original", 4), ("demo", 2)]
    assert set(pooled.decisions["participant"].astype(str)) >= DEMO_CODES


@pytest.mark.parametrize("status", ["not_started", "in_progress"])
def test_links_never_opened_are_no_study_file_and_no_participant(
    mixed_export: Path, tmp_path: Path, status: str
) -> None:
    """``in_progress`` with neither digest nor cell is how exports before ``not_started``
    wrote a link never opened; both are set aside before anything is counted."""
    export = tmp_path / "export"
    shutil.copytree(mixed_export, export)
    path = export / "participants.csv"
    participants = pd.read_csv(path)
    participants.loc[participants["participant"].isin(UNUSED), "status"] = status
    participants.to_csv(path, index=False)
    tables = load_inputs([export], study="original")
    assert [(s.name, s.digest, s.participants) for s in tables.studies] == [
        ("original", ORIGINAL, 4)
    ]
    assert tables.never_opened == 3
    assert not UNUSED & set(tables.all_participants["participant"])
