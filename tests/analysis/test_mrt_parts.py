"""An MRT with a part missing is never reported as the total.

A participant whose export holds part 1 only used to get part 1 (half the
test) as their MRT score: it entered the mean and four correlations while the
demographics table showed the stored total, so the report had two MRT means.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.instrument_measures import incomplete_mrt_note, mrt_scores
from hcss.analysis.load import load_inputs
from hcss.analysis.report import run_analysis
from tests.support.synthetic import study_export


def _one_part_only(export: Path, keep_stored: dict[str, bool]) -> None:
    """Leave only part 1 of these participants' MRT rows; drop their stored total if asked."""
    scores = pd.read_csv(export / "scores.csv", dtype={"participant": str})
    mrt = scores["instrument"] == "mrt"
    one_part = scores["participant"].isin(keep_stored) & mrt & (scores["scale"] != "part_1")
    scores[~one_part].to_csv(export / "scores.csv", index=False)
    people = pd.read_csv(export / "participants.csv", dtype={"participant": str})
    for code, keep in keep_stored.items():
        if not keep:
            people.loc[people["participant"] == code, "mrt_score"] = None
    people.to_csv(export / "participants.csv", index=False)


def test_one_part_gives_the_stored_total_or_nothing(tmp_path: Path):
    export = study_export(tmp_path / "export", participants=8)
    people = pd.read_csv(export / "participants.csv", dtype={"participant": str})
    stored = dict(zip(people["participant"], people["mrt_score"], strict=True))
    _one_part_only(export, {"P00": True, "P01": False})
    tables = load_inputs([export])
    scores = mrt_scores(tables.scores, tables.participants)
    assert scores["P00"] == stored["P00"]  # the stored total, not part 1 (its half)
    assert "P01" not in scores.index  # neither a total nor both parts: missing
    assert scores["P02"] == stored["P02"]
    note = incomplete_mrt_note(tables.scores, tables.participants)
    assert "2 participants have one MRT part only" in note
    assert "P00" in note and "P01" in note
    assert "stored total used for 1, left out: 1" in note


def test_the_report_says_which_mrt_scores_are_incomplete(tmp_path: Path):
    export = study_export(tmp_path / "export", participants=8)
    _one_part_only(export, {"P00": True, "P01": False})
    report = run_analysis([export], tmp_path / "out", progress=False)
    page = report.html_path.read_text()
    assert "have one MRT part only" in page


@pytest.mark.skipif(shutil.which("Rscript") is None, reason="R is not installed (make r)")
def test_analysis_r_recomputes_the_same_mrt_from_the_export_rows(tmp_path: Path):
    """analysis.R summed the parts a participant had, as hcss did: both reported half a test."""
    export = study_export(tmp_path / "export", participants=8)
    people = pd.read_csv(export / "participants.csv", dtype={"participant": str})
    stored = dict(zip(people["participant"], people["mrt_score"], strict=True))
    _one_part_only(export, {"P00": True, "P01": False})
    report = run_analysis([export], tmp_path / "out", progress=False)
    subprocess.run(["Rscript", "analysis.R"], cwd=report.directory, check=True, capture_output=True)
    measures = pd.read_csv(report.directory / "r_measures.csv", dtype={"participant": str})
    mrt = measures[measures["measure"] == "mrt.total"]
    by_person = mrt.set_index("participant")
    assert by_person.loc["P00", "value_r"] == stored["P00"] == by_person.loc["P00", "value_hcss"]
    assert "P01" not in by_person.index
    assert (mrt["value_r"] == mrt["value_hcss"]).all()
