"""The report adapts to its sample: counts first, too-small tests named once, readable figures."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from hcss.analysis.banner import sample_banner
from hcss.analysis.figures import comparison_figure, profile_figure
from hcss.analysis.load import load_inputs
from hcss.analysis.measures import all_measures
from hcss.analysis.sections import build_sections
from tests.support.synthetic import study_export


def test_one_participant_gets_counts_and_one_line_per_test_not_run(tmp_path: Path):
    """One participant printed paired rows with n = 1 and Kruskal-Wallis with ε² = 1.00."""
    tables = load_inputs([study_export(tmp_path / "export", participants=1)])
    banner = sample_banner(tables)
    assert "Participants with decisions per model: M1 1, M2 1, M3 1" in banner.counts
    assert "Participants per counterbalancing cell: cell 1: 1" in banner.counts
    assert len(banner.not_run) == 4
    assert any(reason.startswith("Friedman and paired Wilcoxon") for reason in banner.not_run)
    sections = build_sections(tables, all_measures(tables))
    keys = [section.key for section in sections]
    assert "repeated" not in keys and "independent" not in keys and "correlations" not in keys
    for section in sections:
        assert all(table.rows for table in (*section.tables, *section.details)), section.key
    assert "design" in keys


def test_six_participants_run_every_rank_test_and_list_only_the_models(tmp_path: Path):
    tables = load_inputs([study_export(tmp_path / "export", participants=6)])
    assert sample_banner(tables).not_run == (
        "Decision-level GEE and mixed model: they need 10 or more participants (6); "
        "the GEE's robust errors and the mixed model's participant variance from fewer "
        "participants are not trustworthy",
    )
    keys = [section.key for section in build_sections(tables, all_measures(tables))]
    assert {"independent", "repeated", "correlations", "design"} <= set(keys)


def _measures(measure: str, values: list[float]) -> pd.DataFrame:
    rows = [
        (measure, "overall", model, "study", f"P{index}", f"P{index}", value)
        for model in ("M1", "M2", "M3")
        for index, value in enumerate(values)
    ]
    return pd.DataFrame(
        rows, columns=["measure", "split", "group", "source", "unit", "participant", "value"]
    )


def test_rate_axes_show_the_whole_range():
    """A success rate of 1.0 for everyone drew an axis from 0.96 to 1.04."""
    figure = comparison_figure(_measures("success_rate", [1.0, 1.0]), "success_rate")
    low, high = figure.axes[0].get_ylim()
    assert low <= 0.0 and 1.0 <= high < 1.05
    # two values per model: coloured dots, not a box that draws a line without colour
    assert len(figure.axes[0].patches) == 0
    colours = {tuple(c.get_facecolor()[0]) for c in figure.axes[0].collections}
    assert len(colours) == 3


def test_tlx_profile_has_a_panel_per_kind_and_no_lines_across_subscales():
    scales = ["nasa_tlx.overall", "nasa_tlx.effort_rating", "nasa_tlx.effort_weighted"]
    measures = pd.concat([_measures(scale, [40.0, 60.0]) for scale in scales])
    figure = profile_figure(measures, scales, "NASA-TLX")
    titles = [axes.get_title() for axes in figure.axes]
    assert titles == [
        "Totals (0–100)",
        "Subscale ratings (0–100)",
        "Weighted subscales (rating × weight ÷ 15)",
    ]
    for axes in figure.axes:
        for line in axes.get_lines():
            assert line.get_linestyle() == "None"  # markers and error bars, never a line


def test_demographics_leave_out_visitors_who_never_reached_the_questionnaire():
    """A visitor with no answer at all was counted as "not answered" in every item."""
    from hcss.analysis.sample import demographics_table

    participants = pd.DataFrame(
        {
            "participant": ["P1", "P2", "V1"],
            "age_band": ["18-30", "31-45", None],
            "gender": ["x", "y", None],
            "video_games": [3, 4, None],
        }
    )
    table = demographics_table(participants)
    assert ("age band", "18-30", "1 (50%)") in table.rows
    assert all("not answered" not in row[1] for row in table.rows)


def test_family_tables_drop_p_columns_of_tests_not_run(tmp_path: Path):
    """With one participant every "KW p" and "Friedman p" cell was an en dash."""
    tables = load_inputs([study_export(tmp_path / "export", participants=1)])
    sections = {s.key: s for s in build_sections(tables, all_measures(tables))}
    family = sections["performance"].tables[0]
    assert family.header == (
        "Measure",
        "Split",
        "M1 M (SD)",
        "M2 M (SD)",
        "M3 M (SD)",
        "n (M1/M2/M3)",
    )
    assert family.rows[0][-1] == "1"  # one participant per model, not N = 3


def test_a_family_tables_n_column_names_its_models_and_says_what_it_counts(tmp_path: Path):
    """ "n per model 3/1" named neither the models nor what was counted."""
    tables = load_inputs([study_export(tmp_path / "export", participants=3)])
    sections = {s.key: s for s in build_sections(tables, all_measures(tables))}
    family = sections["performance"].tables[0]
    assert "n (M1/M2/M3)" in family.header
    assert "n: participants" in family.caption
    assert "in the order of the header" in family.caption


def test_a_measure_met_once_per_participant_is_drawn():
    """The MRT (group "All") drew an empty panel: only model groups were drawn."""
    from hcss.analysis.figures import family_figure

    rows = [("mrt.total", "overall", "All", "study", f"P{i}", f"P{i}", 10.0 + i) for i in range(5)]
    measures = pd.DataFrame(
        rows, columns=["measure", "split", "group", "source", "unit", "participant", "value"]
    )
    figure = family_figure(measures, ["mrt.total"], "Mental Rotations Test")
    assert len(figure.axes[0].patches) == 1  # the box of the five scores
