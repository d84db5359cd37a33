"""The study's own tests under its units, against R.

The data are the study's design (28 scenarios × 10 runs per model, 12
decisions a run; 28 participants × M1–M3), made by tests.support.synthetic.
The golden values come from the independent R script beside them,
`fixtures/study_unit_tests.R` (base R: its own units from the decisions,
`wilcox.test(m2, m1, conf.int = TRUE)`, `median(outer(m2, m1, "-"))`,
`cor.test(time, success, method = "spearman")`, `kruskal.test`, and the
Tukey-Kramer mean-rank formula with `ptukey(q, 5, Inf)`), run as

    Rscript fixtures/study_unit_tests.R sim.csv study/ > r.csv

Before these tables the report had only per-scenario tests (n 28 + 28), so
no N, DOF or U of the kind the study prints existed anywhere in it.
"""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from hcss.analysis.load import load_inputs
from hcss.analysis.shift import hodges_lehmann
from hcss.analysis.study_tests import five_group_tables, study_tables
from hcss.cli import main
from tests.support.synthetic import simulation_decisions, study_export, write_table

R_SCRIPT = Path(__file__).parent / "fixtures" / "study_unit_tests.R"
MEASURE = {"success": "success_pct", "time": "time_min"}


@pytest.fixture(scope="module")
def study_design(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("design")
    write_table(simulation_decisions(scenarios=28, runs=10), folder / "sim.csv")
    study_export(folder / "study", participants=28)
    return folder


@pytest.fixture(scope="module")
def frames(study_design: Path) -> dict[str, pd.DataFrame]:
    tables = load_inputs([study_design / "sim.csv", study_design / "study"])
    built = study_tables(tables.decisions) + five_group_tables(tables.decisions)
    return {table.name: table.frame for table in built}


def _row(frame: pd.DataFrame, **where: str) -> pd.Series:
    chosen = frame
    for column, value in where.items():
        chosen = chosen[chosen[column] == value]
    assert len(chosen) == 1, where
    return chosen.iloc[0]


def test_hodges_lehmann_exact_matches_r():
    # x <- c(2.31, 4.07, 3.55, 1.98, 5.12, 3.03, 2.76, 4.44)
    # y <- c(1.52, 2.05, 1.87, 3.11, 2.48, 1.33, 2.92, 1.71, 2.26)
    # wilcox.test(x, y, conf.int = TRUE): estimate 1.2, conf.int 0.27 2.22 (exact)
    x = [2.31, 4.07, 3.55, 1.98, 5.12, 3.03, 2.76, 4.44]
    y = [1.52, 2.05, 1.87, 3.11, 2.48, 1.33, 2.92, 1.71, 2.26]
    shift = hodges_lehmann(x, y)
    assert shift.estimate == pytest.approx(1.2, abs=1e-12)
    assert (shift.lower, shift.upper) == pytest.approx((0.27, 2.22), abs=1e-12)
    assert shift.method.startswith("exact")


def test_the_study_mann_whitney_over_its_units_matches_r(frames):
    table = frames["study_units_mann_whitney"]
    # R (study_unit_tests.R), overall split: success N 672, U 23892.5, W 89003.5,
    # p 2.47686897177369e-39, median(outer) 20, conf.int 19.9999421898334 20.0000764496547;
    # time U 15454, p 1.13570395268697e-59, shift 2.08942492208448 [1.88843052111791,
    # 2.2916965595646]; easy success N 660 U 51976; difficult success N 648 U 13348.
    success = _row(table, measure="success_pct", split="overall")
    assert (success["N"], success["dof"], success["U"], success["W"]) == (672, 1, 23892.5, 89003.5)
    assert success["p"] == pytest.approx(2.47686897177369e-39, rel=1e-9)
    assert success["shift"] == pytest.approx(20.0, abs=1e-9)
    # R's root search stops at tol.root = 1e-4
    assert success["shift_lower"] == pytest.approx(19.9999421898334, abs=1e-4)
    assert success["shift_upper"] == pytest.approx(20.0000764496547, abs=1e-4)
    time = _row(table, measure="time_min", split="overall")
    assert (time["N"], time["U"]) == (672, 15454)
    assert time["p"] == pytest.approx(1.13570395268697e-59, rel=1e-9)
    assert time["shift"] == pytest.approx(2.08942492208448, rel=1e-12)
    assert time["shift_lower"] == pytest.approx(1.88843052111791, abs=1e-4)
    assert time["shift_upper"] == pytest.approx(2.2916965595646, abs=1e-4)
    assert tuple(_row(table, measure="success_pct", split="easy")[["N", "U"]]) == (660, 51976)
    assert tuple(_row(table, measure="success_pct", split="difficult")[["N", "U"]]) == (648, 13348)


def test_the_study_correlations_and_five_groups_match_r(frames):
    spearman = frames["study_units_spearman"]
    # R: cor.test(time, success, method = "spearman") over each model's overall units
    m1 = _row(spearman, group="M1SIM", split="overall")
    assert m1["rho"] == pytest.approx(0.0491992642868466, rel=1e-9)
    assert m1["p"] == pytest.approx(0.36864139108123, rel=1e-9)
    m2 = _row(spearman, group="M2SIM", split="overall")
    assert m2["rho"] == pytest.approx(-0.0219752926371462, rel=1e-9)
    assert m2["p"] == pytest.approx(0.688154279969769, rel=1e-9)
    kruskal = _row(frames["study_five_groups_kruskal"], measure="success_pct", split="overall")
    # R: kruskal.test over M1SIM, M2SIM units and M1-M3 decisions: N 1680 (672 + 1008)
    assert (kruskal["n"], kruskal["df"]) == (1680, 4)
    assert kruskal["chi2"] == pytest.approx(243.447161708935, rel=1e-9)
    assert kruskal["p"] == pytest.approx(1.67899164932673e-51, rel=1e-9)
    pair = _row(
        frames["study_five_groups_tukey_kramer"],
        measure="success_pct",
        split="overall",
        group_a="M1SIM",
        group_b="M2SIM",
    )
    assert pair["difference"] == pytest.approx(-230.605654761905, rel=1e-9)
    assert pair["p"] == pytest.approx(9.04771035870056e-10, rel=1e-6)


@pytest.mark.skipif(shutil.which("Rscript") is None, reason="R is not installed (make r)")
def test_every_number_agrees_with_the_r_script_run_now(study_design: Path, frames):
    """All 192 numbers of every split, measure, model and pair, from R run on the same files."""
    done = subprocess.run(
        ["Rscript", str(R_SCRIPT), str(study_design / "sim.csv"), str(study_design / "study")],
        capture_output=True,
        text=True,
        check=True,
    )
    (study_design / "r.csv").write_text(done.stdout)
    expected = pd.read_csv(study_design / "r.csv", keep_default_na=False)
    assert len(expected) == 192
    for row in expected.itertuples():
        if row.table == "mw":
            ours = _row(
                frames["study_units_mann_whitney"], split=row.split, measure=MEASURE[row.measure]
            )
        elif row.table == "spearman":
            ours = _row(frames["study_units_spearman"], split=row.split, group=f"{row.group}SIM")
        elif row.table == "kw":
            ours = _row(
                frames["study_five_groups_kruskal"], split=row.split, measure=MEASURE[row.measure]
            )
        else:
            a, b = row.group.split()
            ours = _row(
                frames["study_five_groups_tukey_kramer"],
                split=row.split,
                measure=MEASURE[row.measure],
                group_a=a,
                group_b=b,
            )
        value = float(ours[{"N": "n"}.get(row.key, row.key) if row.table == "kw" else row.key])
        if row.key.startswith("shift_"):  # R's root search stops at tol.root = 1e-4
            assert math.isclose(value, row.value, abs_tol=2e-4), row
        elif row.table == "tk" and row.key == "p":  # ptukey integrates to about 1e-9
            assert math.isclose(value, row.value, rel_tol=1e-6, abs_tol=1e-12), row
        else:
            assert math.isclose(value, row.value, rel_tol=1e-9, abs_tol=1e-300), row


def test_the_report_shows_the_study_tests_labelled_as_the_studys(study_design: Path, tmp_path):
    out = tmp_path / "report"
    result = CliRunner().invoke(
        main,
        [
            "analyze",
            str(study_design / "sim.csv"),
            str(study_design / "study"),
            "--out",
            str(out),
            "--quiet",
        ],
    )
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text()
    assert "The study&#x27;s own tests, under its units" in page
    assert "not independent" in page
    assert "Mann-Whitney-Wilcoxon tests per scenario" in page
    for name in (
        "study_units_mann_whitney",
        "study_units_spearman",
        "study_five_groups_kruskal",
        "study_five_groups_tukey_kramer",
    ):
        assert (out / "tables" / f"{name}.csv").exists(), name
    written = pd.read_csv(out / "tables" / "study_units_mann_whitney.csv")
    assert set(written["N"]) >= {672}
