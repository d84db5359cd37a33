"""`hcss plan` end to end on a tiny pool: its export goes through `hcss analyze`, and plan.html
holds the assumptions, the power table with intervals and the predicted tables."""

from __future__ import annotations

import csv

import pytest
from click.testing import CliRunner

from hcss.cli import main


@pytest.mark.slow
def test_plan_writes_power_and_predicted_tables(tmp_path) -> None:
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
