"""Golden values from R 4.2 (Debian r-base-core) for exact ties, missing times and the
Spearman boundary; the R code is beside each value, R is not needed to run these.
"""

from __future__ import annotations

import pandas as pd
import pytest

from hcss.analysis import stats
from hcss.analysis.decision_measures import decision_measures
from hcss.analysis.paired import participant_blocks
from hcss.analysis.r_distributions import EDGEWORTH
from hcss.analysis.repeated import paired_wilcoxon
from tests.support.synthetic import trial_rows

REL = 1e-6

#: Trial totals in whole seconds over ten decisions, per participant (M1, M2).
TOTALS = [(130, 119), (200, 189), (300, 275), (250, 257), (340, 300), (280, 247), (190, 208)]
TOTALS += [(400, 348)]


def _seconds(total: int) -> list[int]:
    """Ten whole-second decision times summing to ``total``."""
    base, extra = divmod(total, 10)
    return [base + (1 if index < extra else 0) for index in range(10)]


def _measures(rows: list[dict]) -> pd.DataFrame:
    decisions = pd.DataFrame(rows)
    decisions["group"] = decisions["model"]  # study rows: the group is the model
    return decision_measures(decisions)


def test_equal_paired_differences_tie_as_in_r():
    """Differences 11/600 twice: the rounded values made them unequal and the p "exact".

    hcss before: V 31, p 0.078125, "exact" (the two 11/600 differences ranked apart).
    R, given the exact differences:
        m1 <- c(130, 200, 300, 250, 340, 280, 190, 400)
        m2 <- c(119, 189, 275, 257, 300, 247, 208, 348)
        wilcox.test((m1 - m2) / 600)  # V = 31, p-value = 0.0796880256743, ties: normal
    (R's own wilcox.test(m1/600, m2/600, paired = TRUE) misses the tie as well, through
    floating point, and prints p 0.078125 "exact".)
    """
    rows = []
    for index, (first, second) in enumerate(TOTALS):
        rows += trial_rows(f"P{index}", "M1", _seconds(first))
        rows += trial_rows(f"P{index}", "M2", _seconds(second))
    blocks = participant_blocks(_measures(rows), "decision_time_min", "overall")
    result = paired_wilcoxon(blocks["M1"], blocks["M2"])
    assert result.statistic == 31
    assert result.p == pytest.approx(0.0796880256743, rel=REL)
    assert result.method.startswith("asymptotic")


def test_a_missing_decision_time_is_left_out_of_the_mean():
    """A decision without a time counted as 0 s, shortening the trial's mean.

    hcss before: (60 + 120 + 0) / (60 · 3) = 1.0 min. R:
        mean(c(60, 120, NA), na.rm = TRUE) / 60  # 1.5
    The decision still counts for success: 2 of 3 correct.
    """
    rows = trial_rows("P1", "M1", [60.0, 120.0, float("nan")])
    rows[2]["correct"] = False
    measures = _measures(rows)
    overall = measures[measures["split"] == "overall"].set_index("measure")["value"]
    assert overall["decision_time_min"] == pytest.approx(1.5, rel=REL)
    assert overall["success_rate"] == pytest.approx(2 / 3, rel=REL)


def test_spearman_at_n_1290_uses_the_edgeworth_series_as_r():
    """R uses prho up to and including n = 1290; hcss switched to t at 1290.

    hcss before: p 0.305365516482169 (the t approximation). R:
        n <- 1290; x <- 1:n; y <- (x * 37) %% 1291
        cor.test(x, y, method = "spearman")  # rho 0.0285600880437332, p 0.305321682910653
    """
    x = list(range(1, 1291))
    y = [(value * 37) % 1291 for value in x]
    result = stats.spearman(x, y)
    assert result.statistic == pytest.approx(0.0285600880437332, rel=REL)
    assert result.p == pytest.approx(0.305321682910653, rel=1e-9)
    assert result.method == EDGEWORTH


#: Six participants × (M1, M2, M3): decision time (min) and success rate.
TIMES = [(2.0, 3.5, 2.5), (4.0, 4.5, 3.0), (1.5, 2.0, 2.5), (3.0, 5.0, 4.0), (2.5, 2.5, 3.5)]
TIMES += [(4.5, 3.5, 5.0)]
SUCCESS = [(0.9, 0.6, 0.7), (0.9, 0.8, 0.6), (1.0, 0.8, 0.9), (0.6, 0.3, 0.5), (0.8, 0.7, 0.6)]
SUCCESS += [(0.4, 0.5, 0.3)]


def test_pooled_human_correlation_counts_each_participant_once():
    """Pooling M1–M3 counted each participant three times: N 18 from 6 people.

    hcss before: N = 18, df 16, rho -0.716017257, p 0.000831718 (as R's
        cor.test(as.vector(time), as.vector(succ), method = "spearman", exact = FALSE)).
    Now one value per participant, the mean over the models they met. R:
        time <- matrix(c(2.0,3.5,2.5, 4.0,4.5,3.0, 1.5,2.0,2.5, 3.0,5.0,4.0, 2.5,2.5,3.5,
                         4.5,3.5,5.0), ncol = 3, byrow = TRUE)
        succ <- matrix(c(0.9,0.6,0.7, 0.9,0.8,0.6, 1.0,0.8,0.9, 0.6,0.3,0.5, 0.8,0.7,0.6,
                         0.4,0.5,0.3), ncol = 3, byrow = TRUE)
        cor.test(rowMeans(time), rowMeans(succ), method = "spearman")
        # rho -0.8285714285714285, p 0.0583333333333333 (exact)
    """
    from hcss.analysis.comparisons import POOLED_HUMAN, correlations

    rows = []
    for index, (times, rates) in enumerate(zip(TIMES, SUCCESS, strict=True)):
        for model, time, rate in zip(("M1", "M2", "M3"), times, rates, strict=True):
            for measure, value in (("decision_time_min", time), ("success_rate", rate)):
                rows.append((measure, "overall", model, "study", f"P{index}", f"P{index}", value))
    measures = pd.DataFrame(
        rows, columns=["measure", "split", "group", "source", "unit", "participant", "value"]
    )
    pooled = [c for c in correlations(measures) if c.group == POOLED_HUMAN]
    assert len(pooled) == 1
    result = pooled[0].result
    assert result is not None
    assert result.n == 6 and result.df == 4
    assert result.statistic == pytest.approx(-0.8285714285714285, rel=REL)
    assert result.p == pytest.approx(0.0583333333333333, rel=REL)
    assert "one value per participant" in pooled[0].note
