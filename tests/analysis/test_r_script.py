"""`Rscript analysis.R` in a report's folder reproduces the report's p-values with R's functions.

R is the independent implementation here: kruskal.test, TukeyHSD, friedman.test,
wilcox.test, cor.test, geepack::geeglm and lme4::lmer recompute every p the report's
tables show. Needs Debian's r-base-core, r-cran-lme4 and r-cran-geepack (`make r`);
skipped with that reason otherwise.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.clustered import success_gee
from hcss.analysis.design_tables import model_table
from hcss.analysis.report import run_analysis
from hcss.analysis.tables import write_paper_table as write_table_files
from tests.support.synthetic import simulation_decisions, study_export, write_table


def _r_with_packages() -> str:
    if shutil.which("Rscript") is None:
        return "Rscript is not installed (make r installs r-base-core, r-cran-lme4, r-cran-geepack)"
    check = subprocess.run(
        ["Rscript", "-e", "library(lme4); library(geepack)"], capture_output=True, text=True
    )
    if check.returncode != 0:
        return "R lacks lme4 or geepack (make r installs r-cran-lme4, r-cran-geepack)"
    return ""


REASON = _r_with_packages()
pytestmark = [pytest.mark.slow, pytest.mark.skipif(bool(REASON), reason=REASON)]

#: Relative agreement per table, and an absolute floor for p-values near 0, where R's
#: ptukey and pchisq(lower.tail = FALSE) keep ~1e-14 absolute precision.
RELATIVE = {
    "kruskal_wallis": 1e-9,
    "friedman": 1e-9,
    "wilcoxon_paired": 1e-9,
    "mann_whitney": 1e-9,
    "spearman": 1e-9,
    "tukey_hsd": 1e-6,
    "gee_success": 1e-4,  # iterative fits with different stopping rules
    "mixedlm_time": 1e-5,
    "mixedlm_time (CR2)": 1e-5,  # clubSandwich's coef_test on lme4's fit
}
ABSOLUTE = 1e-12


@pytest.fixture(scope="module")
def r_pvalues(tmp_path_factory) -> tuple[pd.DataFrame, Path]:
    base = tmp_path_factory.mktemp("rscript")
    export = study_export(base / "export", participants=12, seed=4)
    write_table(simulation_decisions(scenarios=8, runs=2), base / "sim" / "decisions.csv")
    report = run_analysis([export, base / "sim"], base / "report", progress=False)
    completed = subprocess.run(
        ["Rscript", "analysis.R"], cwd=report.directory, capture_output=True, text=True
    )
    assert completed.returncode == 0, completed.stderr
    assert "Logistic mixed model (glmer" in completed.stdout
    assert "R error" not in completed.stdout
    return pd.read_csv(report.directory / "r_pvalues.csv"), report.directory


def _hcss_p_count(directory: Path, table: str) -> int:
    frame = pd.read_csv(directory / "tables" / f"{table}.csv")
    return int(frame["p"].notna().sum())


def test_every_p_value_of_the_report_is_reproduced_by_r(r_pvalues):
    table, directory = r_pvalues
    for name, tolerance in RELATIVE.items():
        rows = table[table["table"] == name]
        assert len(rows), f"no {name} p-values recomputed"
        difference = (rows["p_r"] - rows["p_hcss"]).abs()
        allowed = (tolerance * rows["p_hcss"].abs()).clip(lower=ABSOLUTE)
        worst = rows.assign(difference=difference)[difference > allowed]
        assert worst.empty, f"{name}: R and hcss differ\n{worst.to_string()}"
    for name in ("kruskal_wallis", "friedman", "wilcoxon_paired", "mann_whitney", "tukey_hsd"):
        assert (table["table"] == name).sum() == _hcss_p_count(directory, name), name
    spearman = _hcss_p_count(directory, "spearman")
    assert (table["table"] == "spearman").sum() >= spearman
    print(f"\nRscript analysis.R reproduced {len(table)} p-values")


def test_statistics_and_effect_sizes_are_reproduced_too(r_pvalues):
    """R's H, χ², V, W, ρ, ε², Kendall's W, rank-biserial r and exp(β) beside hcss's."""
    table, _ = r_pvalues
    for column, name in (("stat", "statistics"), ("effect", "effect sizes")):
        rows = table[table[f"{column}_hcss"].notna() & table[f"{column}_r"].notna()]
        assert len(rows) > 100, name
        tolerance = (
            rows["table"]
            .map({"gee_success": 1e-5, "mixedlm_time": 1e-6, "mixedlm_time (CR2)": 1e-5})
            .fillna(1e-9)
        )
        relative = (rows[f"{column}_r"] - rows[f"{column}_hcss"]).abs() / rows[
            f"{column}_hcss"
        ].abs().clip(lower=1e-12)
        assert (relative <= tolerance).all(), rows[relative > tolerance].to_string()
    with_effects = set(table.loc[table["effect_hcss"].notna(), "table"])
    assert {"kruskal_wallis", "friedman", "wilcoxon_paired", "mann_whitney"} <= with_effects


def test_measures_are_recomputed_from_the_export(r_pvalues):
    """Success rates, decision times and the MRT total from the export's own rows, in R."""
    _, directory = r_pvalues
    measures = pd.read_csv(directory / "r_measures.csv")
    assert {"success_rate", "decision_time_min", "mrt.total"} <= set(measures["measure"])
    assert (measures["value_r"] - measures["value_hcss"]).abs().max() <= 1e-9
    assert len(measures[measures["measure"] == "mrt.total"]) == 12


def test_the_script_never_stops_on_a_model_that_was_not_fitted(r_pvalues, tmp_path):
    """An unfitted model's empty table stopped analysis.R at read.csv: no r_pvalues.csv at all."""
    _, directory = r_pvalues
    copy = shutil.copytree(directory, tmp_path / "report")
    decisions = pd.read_csv(copy / "model_decisions.csv", dtype={"participant": str})
    separated = decisions.assign(source="study", correct=True)
    write_table_files(model_table("gee_success", success_gee(separated)), copy / "tables")
    (copy / "tables" / "mixedlm_time.csv").write_text("")  # as older reports wrote it
    (copy / "r_pvalues.csv").unlink()
    completed = subprocess.run(["Rscript", "analysis.R"], cwd=copy, capture_output=True, text=True)
    assert completed.returncode == 0, completed.stderr
    table = pd.read_csv(copy / "r_pvalues.csv")
    assert not table["table"].isin(["gee_success", "mixedlm_time"]).any()
    assert table["table"].isin(["kruskal_wallis", "friedman"]).any()
