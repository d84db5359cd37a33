"""`hcss plan` end to end on a tiny pool: its export goes through `hcss analyze`, and plan.html
holds the assumptions, the power table with intervals and the predicted tables."""

from __future__ import annotations

import csv
import json
import math

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.simulation.presets import DEFAULT_PRESET
from tests.support.axe import axe_violations, summary


@pytest.mark.slow
@pytest.mark.browser
def test_plan_writes_power_and_predicted_tables(tmp_path, browser) -> None:
    out = tmp_path / "plan"
    result = CliRunner().invoke(
        main,
        [
            "plan", "--pool", "8", "--pool-scenarios", "6", "--runs", "1", "--n", "4,6",
            "--replications", "20", "--workers", "1", "--out", str(out),
        ],
    )  # fmt: skip
    assert result.exit_code == 0, result.output
    page = (out / "plan.html").read_text(encoding="utf-8")
    for words in ("Assumptions", "Power per test", "kruskal_wallis", "§11", "data:image/png"):
        assert words in page
    # the shipped population's preset, not the original study file's study-calibrated
    assert f"Model: preset {DEFAULT_PRESET}" in page
    with (out / "export" / "decisions.csv").open(encoding="utf-8") as handle:
        sources = {row["source"] for row in csv.DictReader(handle)}
    assert sources == {"synthetic", "simulation"}
    assert (out / "analysis" / "report.html").exists()  # hcss analyze's own report
    with (out / "power.csv").open(encoding="utf-8") as handle:
        rows = list(csv.DictReader(handle))
    omnibus = [r for r in rows if r["test"] == "kruskal_wallis"]
    assert len(omnibus) == 6  # success and decision time x overall, easy, difficult
    assert all("[" in r["N=4"] and "[" in r["N=6"] for r in rows)
    assert "N for 80%" in rows[0]
    # the study's words about its operators, the first against the pool's collectives alone
    assert "The study's words about its operators" in page
    assert "operators improved both models" in page and "M2 difficult" in page
    # the analyst reads it in a browser: plan.html, then the pool's report it links to, both
    # passing axe-core's WCAG 2.1 A/AA checks
    tab = browser.new_page(viewport={"width": 1024, "height": 620})
    tab.goto((out / "plan.html").as_uri())
    violations = axe_violations(tab)
    assert violations == [], summary(violations)
    tab.get_by_role("link", name="hcss analyze's report of the pool").click()
    tab.wait_for_url("**/analysis/report.html")
    violations = axe_violations(tab)
    assert violations == [], summary(violations)
    tab.close()


def test_the_plan_runs_the_preset_its_population_was_fitted_on(tmp_path) -> None:
    """A population reproduces the human tables under the preset it was fitted on, so the
    plan's model runs that preset, whatever the study file names; the page says which."""
    from hcss.experiments.operators_fit import FITTED_POPULATION, load_population
    from hcss.plan_cli import model_for
    from hcss.simulation.presets import DEFAULT_PRESET

    fitted = json.loads(FITTED_POPULATION.read_text(encoding="utf-8"))
    assert fitted["preset"] == DEFAULT_PRESET  # the shipped fit is of today's default
    load_population(FITTED_POPULATION)  # and its traits are this operator's
    preset, words = model_for(FITTED_POPULATION, "study-calibrated")
    assert preset == DEFAULT_PRESET
    assert f"fitted on preset {DEFAULT_PRESET}" in words and "study-calibrated" in words
    unrecorded = tmp_path / "population.json"
    unrecorded.write_text(json.dumps({k: v for k, v in fitted.items() if k != "preset"}))
    assert model_for(unrecorded, "study-calibrated")[0] == "study-calibrated"


def test_a_population_of_traits_the_operator_does_not_have_is_refused(tmp_path) -> None:
    from hcss.experiments.operators_fit import FITTED_POPULATION, load_population

    old = json.loads(FITTED_POPULATION.read_text(encoding="utf-8"))
    old["median"]["probe_lapse"] = 0.1
    path = tmp_path / "population.json"
    path.write_text(json.dumps(old))
    with pytest.raises(ValueError, match="probe_lapse"):
        load_population(path)


@pytest.mark.parametrize(
    "spoil",
    [
        lambda values: values["median"].pop("hasten_prob"),  # fitted before a trait existed
        lambda values: values["median"].update(probe_lapse=0.1),  # a trait renamed since
        lambda values: values.pop("median"),
        lambda values: values["median"].update(stay_prob=1.7),  # not a probability
        lambda values: values["median"].update(glance_interval_s="soon"),
        lambda values: values["median"].update(glance_interval_s=math.nan),
        lambda values: values["median"].update(push_margin=math.inf),
        lambda values: values["median"].update(stay_prob=True),
        lambda values: values.update(spread="wide"),
    ],
)
def test_a_population_file_the_operator_cannot_use_is_a_clear_error(tmp_path, spoil) -> None:
    """`hcss plan --population` with a file this operator cannot mean what it was fitted to
    mean: exit 2 naming the option, no traceback, no output directory written. A trait
    that is not a finite number (a word, NaN, infinity, true) is named as such."""
    from hcss.experiments.operators_fit import FITTED_POPULATION

    values = json.loads(FITTED_POPULATION.read_text(encoding="utf-8"))
    spoil(values)
    path = tmp_path / "population.json"
    path.write_text(json.dumps(values))
    out = tmp_path / "plan"
    result = CliRunner().invoke(main, ["plan", "--population", str(path), "--out", str(out)])
    assert result.exit_code == 2, result.output
    assert "--population" in result.output and "Traceback" not in result.output
    assert "supported between" not in result.output  # the trait named, not Python's words
    assert not out.exists()


def test_a_population_file_that_is_not_json_is_a_clear_error(tmp_path) -> None:
    path = tmp_path / "population.json"
    path.write_text("median: 1\n")
    result = CliRunner().invoke(
        main, ["plan", "--population", str(path), "--out", str(tmp_path / "o")]
    )
    assert result.exit_code == 2 and "--population" in result.output, result.output
