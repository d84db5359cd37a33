"""`hcss analyze` keeps study files apart: one with --study, several only with --pool-studies."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from hcss.analysis.cli import analyze
from hcss.analysis.load import AnalysisInputError, load_inputs
from tests.analysis.synthetic import study_export

ORIGINAL, DEMO = "a" * 64, "b" * 64
DEMO_CODES = {"P04", "P05"}


@pytest.fixture(scope="module")
def mixed_export(tmp_path_factory) -> Path:
    """A study export whose P04 and P05 ran the demo study file, the rest the original."""
    directory = study_export(tmp_path_factory.mktemp("mixed") / "export")
    path = directory / "participants.csv"
    participants = pd.read_csv(path)
    demo = participants["participant"].isin(DEMO_CODES)
    participants["study"] = participants["study"].where(~demo, "demo")
    participants["study_digest"] = [DEMO if d else ORIGINAL for d in demo]
    participants.to_csv(path, index=False)
    return directory


def test_two_study_files_are_refused_and_named(mixed_export: Path, tmp_path: Path) -> None:
    result = CliRunner().invoke(analyze, [str(mixed_export), "--out", str(tmp_path / "r")])
    assert result.exit_code == 1
    assert "2 different study files" in result.output
    assert "original (aaaaaaaaaaaa): 4 participant(s)" in result.output
    assert "demo (bbbbbbbbbbbb): 2 participant(s)" in result.output
    assert "--study NAME" in result.output and "--pool-studies" in result.output
    assert not (tmp_path / "r").exists()


def test_one_study_is_analysed_and_named_in_the_report(mixed_export: Path, tmp_path: Path) -> None:
    arguments = [str(mixed_export), "--out", str(tmp_path / "r"), "--study", "original", "--quiet"]
    result = CliRunner().invoke(analyze, arguments)
    assert result.exit_code == 0, result.output
    report = (tmp_path / "r" / "report.html").read_text(encoding="utf-8")
    assert "Study files analysed: original (aaaaaaaaaaaa): 4 participant(s)." in report
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
