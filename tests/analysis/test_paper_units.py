"""The study's tables under its own unit (scenario, decision slot), from a hand-made table.

The decisions below are written by hand; every golden value is worked out by
hand in the comments (slots, unit values, N) and the summaries were checked
with Python's `statistics` module (mean, stdev with n − 1, median), not with
the code under test. R gives the same: e.g. ``sd(c(50, 100, 50, 100, 50, 0))``
is 37.63863 and ``median(c(55, 110, 60, 55, 77.5, 110) / 60)`` is 1.145833.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import pandas as pd
import pytest

from hcss import study_units as su
from hcss.analysis.load import load_inputs
from hcss.analysis.paper_units import paper_unit_tables
from hcss.analysis.summary import summarise_decisions
from hcss.simulation.decisions import DECISION_COLUMNS

# (model, scenario, run, section, end_s, collective, difficulty, correct, decision_time_s)
# Slots are numbered in order of completion within a run: section first, then end time.
DECISIONS = [
    # scenario A, M1, run 0: slot 1 = II (end 60), slot 2 = I (end 100), slot 3 = section 2
    ("M1", "A", 0, 1, 100.0, "I", "easy", True, 100.0),
    ("M1", "A", 0, 1, 60.0, "II", "easy", False, 60.0),
    ("M1", "A", 0, 2, 30.0, "I", "difficult", False, 30.0),
    # scenario A, M1, run 1
    ("M1", "A", 1, 1, 50.0, "I", "difficult", True, 50.0),
    ("M1", "A", 1, 1, 120.0, "III", "easy", True, 120.0),
    ("M1", "A", 1, 2, 90.0, "II", "difficult", True, 90.0),
    # scenario B, M1, run 0
    ("M1", "B", 0, 1, 40.0, "I", "easy", True, 40.0),
    ("M1", "B", 0, 1, 80.0, "II", "easy", True, 80.0),
    ("M1", "B", 0, 2, 200.0, "I", "easy", False, 200.0),
    # scenario B, M1, run 1
    ("M1", "B", 1, 1, 70.0, "I", "easy", True, 70.0),
    ("M1", "B", 1, 1, 75.0, "II", "difficult", False, 75.0),
    ("M1", "B", 1, 2, 20.0, "III", "difficult", False, 20.0),
    # scenario A, M2, one run: slot 1 easy, slot 2 difficult
    ("M2", "A", 0, 1, 10.0, "I", "easy", True, 10.0),
    ("M2", "A", 0, 1, 20.0, "II", "difficult", True, 20.0),
]

# The units of M1, by hand (success %, time in seconds):
#   A1: run 0 easy ✗ 60 s, run 1 difficult ✓ 50 s -> overall 50, 55 s; easy 0, 60; difficult 100, 50
#   A2: run 0 easy ✓ 100, run 1 easy ✓ 120        -> overall 100, 110; easy 100, 110
#   A3: run 0 difficult ✗ 30, run 1 difficult ✓ 90 -> overall 50, 60; difficult 50, 60
#   B1: easy ✓ 40, easy ✓ 70                      -> overall 100, 55; easy 100, 55
#   B2: easy ✓ 80, difficult ✗ 75                 -> overall 50, 77.5; easy 100, 80; difficult 0, 75
#   B3: easy ✗ 200, difficult ✗ 20                -> overall 0, 110; easy 0, 200; difficult 0, 20
# So M1 has 6 units overall, 5 with an easy decision, 4 with a difficult one.
# Columns (statistics.mean / stdev / median / min / max of the lists above):
GOLDEN = {
    # SR overall [50, 100, 50, 100, 50, 0]
    ("M1", "overall", "success_pct"): (6, 58.333333, 37.638633, 50.0, 0.0, 100.0),
    # time overall [55, 110, 60, 55, 77.5, 110] / 60
    ("M1", "overall", "time_min"): (6, 1.298611, 0.436540, 1.145833, 55 / 60, 110 / 60),
    # SR easy [0, 100, 100, 100, 0]
    ("M1", "easy", "success_pct"): (5, 60.0, 54.772256, 100.0, 0.0, 100.0),
    # time easy [60, 110, 55, 80, 200] / 60
    ("M1", "easy", "time_min"): (5, 1.683333, 0.990230, 80 / 60, 55 / 60, 200 / 60),
    # SR difficult [100, 50, 0, 0]
    ("M1", "difficult", "success_pct"): (4, 37.5, 47.871355, 25.0, 0.0, 100.0),
    # time difficult [50, 60, 75, 20] / 60
    ("M1", "difficult", "time_min"): (4, 0.854167, 0.387149, 55 / 60, 20 / 60, 75 / 60),
}


def write_decisions(path: Path) -> Path:
    """The hand-made decisions as a decisions table with every column of the data dictionary."""
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.DictWriter(handle, fieldnames=DECISION_COLUMNS)
        writer.writeheader()
        for i, (model, scenario, run, section, end, coll, kind, correct, secs) in enumerate(
            DECISIONS
        ):
            row = {column: "" for column in DECISION_COLUMNS}
            row.update(
                source="simulation",
                model=model,
                trial_id=f"{scenario}-{model}-r{run}",
                scenario_id=scenario,
                run=run,
                seed=1,
                first_section="easy",
                section=section,
                section_kind="easy",
                collective=coll,
                decision_index=i + 1,
                difficulty=kind,
                start_s=end - secs,
                end_s=end,
                decision_time_s=secs,
                timed_out=False,
                correct=correct,
                n_requests=0,
                n_investigate=0,
                n_abandon=0,
                n_decide=0,
                n_interventions=0,
            )
            writer.writerow(row)
    return path


def test_units_follow_the_studys_rule_on_a_hand_made_table(tmp_path: Path) -> None:
    frame = load_inputs([write_decisions(tmp_path / "decisions.csv")]).decisions
    summaries = su.summarise(su.units(frame.to_dict("records")))
    for key, (n, mean, sd, median, low, high) in GOLDEN.items():
        got = summaries[key]
        assert got.n == n, key
        assert (got.mean, got.sd, got.median, got.minimum, got.maximum) == pytest.approx(
            (mean, sd, median, low, high), abs=1e-6
        ), key
    # M2: one run, slot 1 easy ✓ 10 s, slot 2 difficult ✓ 20 s. Both models together:
    # 6 + 2 units overall, 5 + 1 with an easy decision, 4 + 1 with a difficult one.
    assert su.unit_counts(summaries) == {"overall": 8, "easy": 6, "difficult": 5}
    assert summaries[("M2", "difficult", "time_min")].mean == pytest.approx(20 / 60)
    # One run per slot, two units, both correct: SD 0 over units (n − 1 = 1).
    assert summaries[("M2", "overall", "success_pct")].sd == 0.0
    assert math.isnan(summaries[("M2", "easy", "success_pct")].sd)  # one unit: no SD


def test_simulate_experiments_summary_prints_and_writes_the_unit_tables(tmp_path: Path) -> None:
    text = summarise_decisions(write_decisions(tmp_path / "decisions.csv"))
    assert "decision slot" in text  # the caption states the unit and its rule
    # The paper's layout: this run's row, then the study's, per model.
    assert "| M1 | this run | 6 / 5 / 4 | 58.3 (37.6), 50.0 (0.0/100.0) |" in text
    assert "| M1 | study | 336 / – / – | 52.1 (39.4), 60.0 (0.0/100.0) |" in text
    written = pd.read_csv(tmp_path / "paper_units_time.csv")
    easy = written[
        (written["model"] == "M1")
        & (written["source"] == "this run")
        & (written["split"] == "easy")
    ].iloc[0]
    assert (easy["n"], easy["median"]) == (5, pytest.approx(80 / 60))
    study = written[(written["source"] == "study") & (written["split"] == "difficult")]
    assert sorted(study["mean"]) == [3.2, 5.77]


def test_no_unit_tables_without_simulation_rows(tmp_path: Path) -> None:
    frame = load_inputs([write_decisions(tmp_path / "decisions.csv")]).decisions
    assert paper_unit_tables(frame.assign(source="study")) == []


def test_loss_counts_every_fitted_published_number_once() -> None:
    exact = dict(su.PUBLISHED)
    # N per split (both models) is fitted too: give each model half of the study's units.
    shares = {"overall": 336, "easy": 289, "difficult": 228}
    exact = {
        key: su.Summary(shares[key[1]], s.mean, s.sd, s.median, s.minimum, s.maximum)
        for key, s in exact.items()
    }
    assert su.loss(exact) == 0.0
    assert su.numbers_met(exact) == len(su.distances(exact)) == 12 * 3 + 2
    off = dict(exact)
    s = off[("M2", "easy", "success_pct")]
    off[("M2", "easy", "success_pct")] = su.Summary(s.n, s.mean - 20, s.sd, s.median, 0, 100)
    assert su.loss(off) == pytest.approx(4.0)  # 20 points = two bands, squared
    assert su.numbers_met(off) == 37


def test_hcss_analyze_puts_the_unit_tables_in_the_simulation_section(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from hcss.analysis.cli import analyze
    from tests.support.synthetic import simulation_decisions, write_table

    decisions = simulation_decisions(scenarios=4, runs=2)
    write_table(decisions, tmp_path / "decisions.csv")
    result = CliRunner().invoke(
        analyze, [str(tmp_path / "decisions.csv"), "--out", str(tmp_path / "report")]
    )
    assert result.exit_code == 0, result.output
    written = pd.read_csv(tmp_path / "report" / "tables" / "paper_units_success.csv")
    ours = written[(written["source"] == "this run") & (written["split"] == "overall")]
    # One unit per (scenario, slot): 4 scenarios × the slots of the longest run.
    slots = decisions.groupby(["model", "scenario_id", "run"]).size().groupby("model").max()
    assert dict(zip(ours["model"], ours["n"], strict=True)) == {
        model: 4 * int(n) for model, n in slots.items()
    }
    assert "decision slot" in (tmp_path / "report" / "report.html").read_text()
