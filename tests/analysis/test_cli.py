"""`hcss analyze` end to end, on generated simulation and study exports."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner
from scipy.stats import mannwhitneyu

from hcss.analysis.cli import analyze
from tests.support.synthetic import simulation_decisions, study_export, write_table


def run(*arguments: str):
    return CliRunner().invoke(analyze, list(arguments), catch_exceptions=False)


@pytest.fixture(scope="module")
def simulation_report(tmp_path_factory) -> Path:
    base = tmp_path_factory.mktemp("simulation")
    write_table(simulation_decisions(scenarios=8, runs=3), base / "experiment" / "decisions.csv")
    result = run(str(base / "experiment" / "decisions.csv"), "--out", str(base / "report"))
    assert result.exit_code == 0, result.output
    assert "hcss analyze" in result.stderr  # the progress bar
    return base / "report"


def test_simulation_report_tables(simulation_report: Path):
    tables = simulation_report / "tables"
    for name in ("descriptive_success_rate", "descriptive_decision_time_min", "mann_whitney"):
        for suffix in ("md", "tex", "csv"):
            assert (tables / f"{name}.{suffix}").stat().st_size > 0
    # human-only measures have nothing to say about simulation runs
    assert not (tables / "descriptive_request_frequency.csv").exists()
    summary = pd.read_csv(tables / "descriptive_success_rate.csv")
    assert set(summary["group"]) == {"M1SIM", "M2SIM"}
    assert set(summary["split"]) == {"overall", "easy", "difficult"}
    assert (summary["n"] == 8).all()  # one unit per scenario, runs averaged


def test_simulation_mann_whitney_matches_the_measures(simulation_report: Path):
    tests = pd.read_csv(simulation_report / "tables" / "mann_whitney.csv")
    assert len(tests) == 6
    assert set(zip(tests["measure"], tests["split"], strict=True)) == {
        (measure, split)
        for measure in ("success_rate", "decision_time_min")
        for split in ("overall", "easy", "difficult")
    }
    measures = pd.read_csv(simulation_report / "measures.csv")
    row = tests[(tests["measure"] == "decision_time_min") & (tests["split"] == "overall")].iloc[0]
    chosen = measures[
        (measures["measure"] == "decision_time_min") & (measures["split"] == "overall")
    ]
    m1 = chosen[chosen["group"] == "M1SIM"]["value"]
    m2 = chosen[chosen["group"] == "M2SIM"]["value"]
    expected = mannwhitneyu(m1, m2, method="exact")  # 8 vs 8, no ties: R uses exact
    assert row["U"] == expected.statistic
    assert row["p"] == pytest.approx(expected.pvalue, rel=1e-9)
    assert row["method"] == "exact"


def test_simulation_figures_and_report(simulation_report: Path):
    for measure in ("success_rate", "decision_time_min"):
        assert (simulation_report / "figures" / f"{measure}.svg").read_text().startswith("<?xml")
        png = (simulation_report / "figures" / f"{measure}.png").read_bytes()
        assert png.startswith(b"\x89PNG")
    page = (simulation_report / "report.html").read_text()
    assert 'src="figures/success_rate.svg"' in page
    assert 'id="mann_whitney"' in page and 'id="descriptive_decision_time_min"' in page


@pytest.fixture(scope="module")
def study_report(tmp_path_factory) -> tuple[Path, Path]:
    base = tmp_path_factory.mktemp("study")
    export = study_export(base / "export", participants=5)
    write_table(simulation_decisions(scenarios=5, runs=2), base / "simulation" / "decisions.csv")
    result = run(str(export), str(base / "simulation"), "--out", str(base / "report"), "--quiet")
    assert result.exit_code == 0, result.output
    return export, base / "report"


def test_study_export_gives_every_table(study_report):
    _, report = study_report
    names = {path.stem for path in (report / "tables").glob("*.csv")}
    expected = {
        "descriptive_success_rate",
        "descriptive_decision_time_min",
        "descriptive_request_frequency",
        "descriptive_investigate_frequency",
        "descriptive_abandon_frequency",
        "descriptive_decide_frequency",
        "descriptive_interventions",
        "descriptive_collective_observations",
        "descriptive_target_observations",
        "descriptive_sa_overall",
        "descriptive_sa_level1",
        "descriptive_sa_level2",
        "descriptive_sa_level3",
        "descriptive_nasa_tlx_overall",
        "descriptive_nasa_tlx_mental_demand_weighted",
        "descriptive_sart_overall",
        "descriptive_sart_su",
        "descriptive_post_trial_responsiveness",
        "descriptive_ranking_performance",
        "descriptive_mrt_total",
        "kruskal_wallis",
        "tukey_kramer_ranks",
        "dunn_holm",
        "tukey_hsd",
        "mann_whitney",
        "spearman",
    }
    assert expected <= names
    for name in names:
        assert (report / "tables" / f"{name}.md").exists()
        assert (report / "tables" / f"{name}.tex").exists()


def test_study_tests_cover_models_and_exclude_bots(study_report):
    _, report = study_report
    kruskal = pd.read_csv(report / "tables" / "kruskal_wallis.csv")
    human = kruskal[kruskal["family"] == "human-collective models"]
    assert set(human["groups"]) == {"M1,M2,M3"}
    overall = human[(human["measure"] == "success_rate") & (human["split"] == "overall")].iloc[0]
    assert overall["n"] == 15  # 5 real participants x 3 models; bot and pilot excluded
    assert overall["epsilon_squared"] == pytest.approx(overall["H"] / 14)
    everyone = kruskal[kruskal["family"] == "all models"]
    assert set(everyone["measure"]) == {"success_rate", "decision_time_min"}
    spearman = pd.read_csv(report / "tables" / "spearman.csv")
    assert {
        "decision_time_min",
        "request_frequency",
        "investigate_frequency",
        "decide_frequency",
        "abandon_frequency",
    } <= set(spearman["x"])
    # the MRT's correlations are shown once, in the MRT section
    assert "mrt.total" not in set(spearman["x"])
    mrt = pd.read_csv(report / "tables" / "spearman_mrt.csv")
    assert set(mrt["x"]) == {"mrt.total"}
    measures = pd.read_csv(report / "measures.csv")
    assert not measures["participant"].astype(str).str.startswith(("BOT", "PILOT")).any()


def test_include_pilot_keeps_flagged_participants(study_report, tmp_path):
    export, _ = study_report
    result = run(str(export), "--out", str(tmp_path / "all"), "--include-pilot", "--quiet")
    assert result.exit_code == 0, result.output
    measures = pd.read_csv(tmp_path / "all" / "measures.csv")
    assert {"BOT1", "PILOT1"} <= set(measures["participant"].astype(str))
    assert "included" in (tmp_path / "all" / "report.html").read_text()


def test_unknown_directory_is_a_clear_error(tmp_path):
    result = run(str(tmp_path / "missing"), "--out", str(tmp_path / "report"))
    assert result.exit_code == 2
    assert "does not exist" in result.output


@pytest.mark.parametrize(
    ("content", "message"),
    [("", "is empty"), ("source,model\nstudy,M1\n", "lacks column(s) participant")],
)
def test_bad_tables_are_clear_errors(tmp_path, content, message):
    (tmp_path / "decisions.csv").write_text(content)
    result = run(str(tmp_path), "--out", str(tmp_path / "report"))
    assert result.exit_code == 1
    assert "Error:" in result.output and message in result.output
    assert "Traceback" not in result.output


def test_mann_whitney_options_reach_the_table(tmp_path):
    write_table(simulation_decisions(scenarios=8, runs=3), tmp_path / "decisions.csv")
    out = tmp_path / "report"
    result = run(
        str(tmp_path / "decisions.csv"),
        "--out",
        str(out),
        "--quiet",
        "--mw-method",
        "asymptotic",
        "--no-continuity",
    )
    assert result.exit_code == 0, result.output
    tests = pd.read_csv(out / "tables" / "mann_whitney.csv")
    assert set(tests["method"]) == {"asymptotic, continuity=False"}
    measures = pd.read_csv(out / "measures.csv")
    chosen = measures[(measures["measure"] == "success_rate") & (measures["split"] == "overall")]
    expected = mannwhitneyu(
        chosen[chosen["group"] == "M1SIM"]["value"],
        chosen[chosen["group"] == "M2SIM"]["value"],
        method="asymptotic",
        use_continuity=False,
    )
    row = tests[(tests["measure"] == "success_rate") & (tests["split"] == "overall")].iloc[0]
    assert row["p"] == pytest.approx(expected.pvalue, rel=1e-9)


@pytest.mark.filterwarnings("error")
def test_one_simulation_model_and_bare_study_export_still_report(tmp_path):
    """Tests that cannot run are explained in the table, not a crash, and no library warning
    reaches the terminal (the GEE's sandwich errors of three participants printed
    "RuntimeWarning: invalid value encountered in sqrt")."""
    decisions = simulation_decisions(scenarios=3, runs=2)
    write_table(decisions[decisions["model"] == "M1"], tmp_path / "m1.csv")
    export = study_export(tmp_path / "export", participants=3)
    for name in ("requests", "observations", "probes", "scores", "questionnaire_items"):
        (export / f"{name}.csv").unlink()
    out = tmp_path / "report"
    result = run(str(tmp_path / "m1.csv"), str(export), "--out", str(out), "--quiet")
    assert result.exit_code == 0, result.output
    tests = pd.read_csv(out / "tables" / "mann_whitney.csv")
    assert tests["U"].isna().all()
    assert tests["note"].str.contains("both samples").all()
    names = {path.stem for path in (out / "tables").glob("*.csv")}
    assert {"descriptive_request_frequency", "descriptive_mrt_total", "kruskal_wallis"} <= names
    assert "descriptive_sa_overall" not in names  # no probes exported, no probe table


def test_independent_tests_warn_about_the_design_and_paired_tests_respect_it(study_report):
    _, report = study_report
    kruskal = pd.read_csv(report / "tables" / "kruskal_wallis.csv")
    human = kruskal[kruskal["family"] == "human-collective models"]
    # 5 participants, each meeting M1, M2 and M3
    assert human["note"].str.contains("n < 10 in M1, M2, M3").all()
    assert human["note"].str.contains("groups share 5 participants").all()
    friedman = pd.read_csv(report / "tables" / "friedman.csv")
    row = friedman[(friedman["measure"] == "success_rate") & (friedman["split"] == "overall")]
    assert row["n"].item() == 5 and row["df"].item() == 2
    assert row["kendall_w"].item() == pytest.approx(row["chi2"].item() / (5 * 2))
    assert "n = 5 < 10" in row["note"].item()
    paired = pd.read_csv(report / "tables" / "wilcoxon_paired.csv")
    chosen = paired[(paired["measure"] == "success_rate") & (paired["split"] == "overall")]
    assert list(zip(chosen["group_a"], chosen["group_b"], strict=True)) == [
        ("M1", "M2"),
        ("M1", "M3"),
        ("M2", "M3"),
    ]
    assert (chosen["p_holm"] >= chosen["p"]).all()
    matrix = pd.read_csv(report / "tables" / "pmatrix_performance.csv")
    assert set(matrix["test"]) == {"tukey_kramer_ranks", "wilcoxon_holm"}
    page = (report / "report.html").read_text()
    assert "Tests that respect the design" in page and "do not respect" in page
