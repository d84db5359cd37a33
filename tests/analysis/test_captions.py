"""What the report claims and captions say matches what was computed (issue 33, item 7)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hcss.analysis.clustered import success_gee
from hcss.analysis.design_tables import model_table
from hcss.analysis.repeated import friedman, paired_wilcoxon
from hcss.analysis.tables import effect_cell, write_paper_table

FIXTURES = Path(__file__).parent / "fixtures"


def test_ties_are_those_of_the_exact_values_as_r_with_digits_rank_7():
    """The docs said "the ties R sees"; R's default sees none between these doubles.

    R 4.2.2:
    x <- c(130/600 - 119/600, 200/600 - 189/600, 0.05, -0.03, 0.2); x[1] == x[2]   # FALSE
    wilcox.test(x)$p.value                     # 0.3125 (no tie: exact p)
    wilcox.test(x, digits.rank = 7)$p.value    # 0.278517 (the tie)
    wilcox.test(c(11/600, 11/600, 0.05, -0.03, 0.2))$p.value   # 0.278517 (exact values)
    """
    result = paired_wilcoxon(
        [130 / 600, 200 / 600, 0.05, 0, 0.2], [119 / 600, 189 / 600, 0, 0.03, 0]
    )
    assert result.p == pytest.approx(0.278517, rel=1e-6)
    docs = (Path(__file__).parents[2] / "docs" / "analysis.md").read_text(encoding="utf-8")
    assert "digits.rank = 7" in docs and "the ties R sees" not in docs


def test_an_unfitted_model_says_why_not_that_order_did_not_vary(tmp_path: Path):
    """Captioned "order did not vary: no order term" though order varied; its CSV was empty."""
    frame = pd.read_csv(FIXTURES / "clustered_twelve.csv", dtype={"participant": str})
    decisions = frame.assign(source="study", correct=True)
    participants = frame[["participant", "model_order"]].drop_duplicates()
    table = model_table("gee_success", success_gee(decisions, participants))
    assert "order did not vary" not in table.caption
    assert table.caption.startswith(
        "Success by model × difficulty: not fitted (every decision was correct: "
        "no variation in success to model)"
    )
    (csv,) = [path for path in write_paper_table(table, tmp_path) if path.suffix == ".csv"]
    written = pd.read_csv(csv)
    assert written.loc[0, "term"] == "not fitted"
    assert written.loc[0, "note"] == "every decision was correct: no variation in success to model"


def test_a_dropped_bootstrap_interval_says_why_in_its_cell():
    """Interventions, almost all 0: Kendall's W printed as a bare number before."""
    blocks = pd.DataFrame(np.array([[0, 0, 0]] * 9 + [[0, 0, 1]], dtype=float))
    result = friedman(blocks)
    assert effect_cell(result) == (
        f"{result.effect_size:.2f} (no CI: bootstrap degenerate: "
        "the resampled statistic is constant or undefined)"
    )
