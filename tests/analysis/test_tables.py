"""Descriptive summaries and the three table formats."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from hcss.analysis.builders import descriptive_tables
from hcss.analysis.descriptive import descriptive_frame, summarise
from hcss.analysis.tables import (
    Table,
    format_p,
    latex_escape,
    to_latex,
    to_markdown,
    write_paper_table,
)


def test_summary_uses_sample_sd():
    summary = summarise([1, 2, 3, 4, float("nan")])
    assert summary.n == 4
    assert summary.mean == 2.5
    assert summary.sd == pytest.approx(math.sqrt(5 / 3))  # sum of squares 5, n - 1 = 3
    assert (summary.median, summary.minimum, summary.maximum) == (2.5, 1, 4)
    assert math.isnan(summarise([7]).sd)


def _measures():
    rows = []
    for group, values in {"M1": [0.5, 1.0], "M2SIM": [0.25, 0.75, 1.0]}.items():
        for unit, value in enumerate(values):
            for split in ("overall", "difficult"):
                rows.append(("success_rate", split, group, "x", str(unit), "", value))
    return pd.DataFrame(
        rows, columns=["measure", "split", "group", "source", "unit", "participant", "value"]
    )


def test_descriptive_table_has_mean_over_sd_and_median_over_range():
    (table,) = descriptive_tables(descriptive_frame(_measures()))
    assert table.name == "descriptive_success_rate"
    assert table.header[1:] == (
        "Overall mean (SD)",
        "Overall median (min–max)",
        "Difficult mean (SD)",
        "Difficult median (min–max)",
    )
    # simulation model first, as in the study's figure; SD of (.25, .75, 1) = .3819
    assert table.rows[0] == ("M2SIM (n = 3)", "0.67", "0.75", "0.67", "0.75")
    assert table.rows[1] == ("", "(0.38)", "(0.25–1.00)", "(0.38)", "(0.25–1.00)")
    assert table.rows[2][0] == "M1 (n = 2)"
    assert table.rows[3][1] == "(0.35)"  # sd of (.5, 1) = .3536
    assert list(table.frame["group"]) == ["M2SIM", "M2SIM", "M1", "M1"]


def test_formats(tmp_path):
    table = Table(
        "spearman",  # a table with a contract (hcss.tablespec.analysis): its CSV is checked
        "χ² and 10% of a_b",
        ("Measure", "p"),
        (("H & more", format_p(0.0004)), ("x", format_p(0.0512))),
        pd.DataFrame({"x": ["a", "b"], "y": ["c", "d"], "group": ["M1", "M2"]}).assign(
            p=[0.0004, 0.0512]
        ),
    )
    markdown = to_markdown(table)
    assert "| H & more | < .001 |" in markdown
    assert "| x | .051 |" in markdown
    latex = to_latex(table)
    assert r"\toprule" in latex and r"\midrule" in latex and r"\bottomrule" in latex
    assert r"H \& more & $<$ .001 \\" in latex
    assert r"\caption{$\chi^2$ and 10\% of a\_b}" in latex
    paths = write_paper_table(table, tmp_path)
    assert [path.suffix for path in paths] == [".md", ".tex", ".csv"]
    assert pd.read_csv(paths[2])["p"].tolist() == [0.0004, 0.0512]


def test_latex_escape_and_p_format_edges():
    assert latex_escape("M1 − M2 ~ 5$") == r"M1 -- M2 \textasciitilde{} 5\$"
    assert format_p(1.0) == "1.000"
    assert format_p(0.5) == ".500"
    assert format_p(float("nan")) == "–"


def test_sample_attrition_and_demographics_tables():
    from hcss.analysis.sample import attrition_table, demographics_table, sample_table

    participants = pd.DataFrame(
        {
            "participant": ["P1", "P2", "P3", "B1"],
            "is_bot": [False, False, False, True],
            "is_pilot": [False, False, False, False],
            "is_demo": [False, False, False, False],
            "status": ["completed", "aborted", "completed", "completed"],
            "gender": ["f", "m", "f", "x"],
            "video_games": [1, 3, 5, None],
        }
    )
    sample = sample_table(participants, include_pilot=False).frame.set_index("row")["n"]
    assert sample["Enrolled (real participants)"] == 3
    assert sample["Completed"] == 2 and sample["Stopped before the end (aborted or withdrew)"] == 1
    assert sample["Excluded: bots"] == 1
    timings = pd.DataFrame(
        {
            "participant": ["P1", "P1", "P2", "P2", "P3", "P3"],
            "stage": ["consent", "trial", "consent", "trial", "consent", "trial"],
            "entered_at": ["t"] * 6,
            "submitted_at": ["t", "t", "t", None, "t", "t"],
        }
    )  # no stage_index column: rows' order is the protocol's
    attrition = attrition_table(timings).frame
    assert attrition["stage"].tolist() == ["consent", "trial"]
    assert attrition["lost"].tolist() == [0, 1]
    demographics = demographics_table(participants[participants["participant"] != "B1"]).frame
    genders = demographics[demographics["item"] == "gender"].set_index("value")["n"]
    assert genders.to_dict() == {"f": 2, "m": 1}
    games = demographics[demographics["item"] == "video_games"].iloc[0]
    assert games["mean"] == 3 and games["sd"] == 2


def test_a_constant_measure_shows_no_p_but_says_all_values_equal():
    import warnings

    from hcss.analysis.builders import kruskal_table, posthoc_tables
    from hcss.analysis.comparisons import omnibus_comparisons

    rows = [
        ("success_rate", "overall", model, "study", f"P{unit}", f"P{unit}", 1.0)
        for model in ("M1", "M2", "M3")
        for unit in range(4)
    ]
    measures = pd.DataFrame(
        rows, columns=["measure", "split", "group", "source", "unit", "participant", "value"]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        comparisons = omnibus_comparisons(measures)
    table = kruskal_table(comparisons)
    (row,) = table.rows
    assert row[3:6] == ("–", "–", "–")  # no statistic, p or effect that looks like a result
    assert "all values equal" in row[7]
    for posthoc in posthoc_tables(comparisons):
        assert all(cells[-1] == "–" for cells in posthoc.rows)
