"""Golden values from R 4.2 (Debian r-base-core, r-cran-rstatix) for the corners where
hcss used to disagree with R: float-noise ties, exact Mann-Whitney with ties, Spearman's
exact p, degenerate data, Tukey HSD with a group of one, and the repeated-measures tests.

Each golden value has the R code that produced it beside it; R is not needed to run these.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
import pytest

from hcss.analysis import posthoc, repeated, stats
from hcss.analysis.decision_measures import decision_measures
from hcss.analysis.r_distributions import EDGEWORTH, EXACT, T_APPROXIMATION
from tests.support.synthetic import SCORES, trial_rows

REL = 1e-6


def test_equal_total_times_are_equal_measures_and_kruskal_wallis_agrees_with_r():
    """Two trials of 640 s over 5 decisions: one value, so ranked as a tie (failed before)."""
    rows = trial_rows("A", "M1", [90, 100, 130, 150, 170])  # 640 s; mean of s/60 was 1 ulp off
    rows += trial_rows("B", "M2", [128] * 5)  # 640 s
    for participant, model, total in [
        ("C", "M1", 600),
        ("D", "M1", 700),
        ("E", "M2", 500),
        ("F", "M2", 650),
        ("G", "M3", 800),
        ("H", "M3", 720),
        ("I", "M3", 660),
    ]:
        rows += trial_rows(participant, model, [total / 5] * 5)
    decisions = pd.DataFrame(rows)
    decisions["group"] = decisions["model"]  # study rows: the group is the model
    measures = decision_measures(decisions)
    times = measures[
        (measures["measure"] == "decision_time_min") & (measures["split"] == "overall")
    ]
    by_participant = times.set_index("participant")["value"]
    assert by_participant["A"] == by_participant["B"] == pytest.approx(640 / 300, abs=1e-9)
    groups = {model: chosen["value"] for model, chosen in times.groupby("group")}
    # m1 <- c(sum(c(90,100,130,150,170)), 600, 700)/300
    # m2 <- c(sum(rep(128,5)), 500, 650)/300; m3 <- c(800, 720, 660)/300
    # kruskal.test(list(m1, m2, m3))  # chi-squared = 4.504201681, df = 2, p = 0.10517803
    result = stats.kruskal_wallis(groups)
    assert result.statistic == pytest.approx(4.504201681, rel=REL)
    assert result.p == pytest.approx(0.10517803, rel=REL)


def test_mann_whitney_exact_with_ties_falls_back_to_normal_like_r():
    # x <- c(1,2,2,3,5); y <- c(3,4,4,5,6)
    # wilcox.test(x, y, exact = TRUE)  # W = 4, p = 0.0906883662,
    #   warning: cannot compute exact p-value with ties
    result = stats.mann_whitney([1, 2, 2, 3, 5], [3, 4, 4, 5, 6], method="exact")
    assert result.statistic == 4
    assert result.p == pytest.approx(0.0906883662, rel=REL)
    assert result.method == "asymptotic, continuity=True (ties: no exact p)"
    assert "cannot compute exact p-value with ties" in result.note
    assert stats.mann_whitney_u(result, 5, 5) == 4  # min(4, 25 - 4)


@pytest.mark.parametrize(
    ("x", "y", "rho", "p", "method"),
    [
        # cor.test(1:7, c(2,1,4,3,7,5,6), method = "spearman")  # rho 0.821428571429, p 0.034126984127
        (list(range(1, 8)), [2, 1, 4, 3, 7, 5, 6], 0.821428571429, 0.034126984127, EXACT),
        # cor.test(c(1,4,2,8,5,7,3,6,9), c(3,1,4,9,2,8,5,7,6), method = "spearman")
        #   rho 0.65, p 0.0665619488536 (n = 9: still exact)
        ([1, 4, 2, 8, 5, 7, 3, 6, 9], [3, 1, 4, 9, 2, 8, 5, 7, 6], 0.65, 0.0665619488536, EXACT),
        # cor.test(1:12, c(5,1,4,3,12,2,6,9,7,8,11,10), method = "spearman")
        #   rho 0.6573426573427, p 0.0239810831715 (n > 9: Edgeworth series)
        (
            list(range(1, 13)),
            [5, 1, 4, 3, 12, 2, 6, 9, 7, 8, 11, 10],
            0.6573426573427,
            0.0239810831715,
            EDGEWORTH,
        ),
        # cor.test(1:8, c(2,1,4,3,7,5,6,6), method = "spearman")
        #   rho 0.8024095954819, p 0.0165407228007 (ties: t approximation, with a warning)
        (
            list(range(1, 9)),
            [2, 1, 4, 3, 7, 5, 6, 6],
            0.8024095954819,
            0.0165407228007,
            T_APPROXIMATION,
        ),
    ],
)
def test_spearman_p_follows_r_default(x, y, rho, p, method):
    result = stats.spearman(x, y)
    assert result.statistic == pytest.approx(rho, rel=REL)
    assert result.p == pytest.approx(p, rel=REL)
    assert result.method == method


def test_degenerate_data_give_nan_with_a_note_and_no_warnings():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any library warning fails the test
        # kruskal.test(list(c(1, 1), c(1, 1, 1)))  # chi-squared = NaN, p-value = NA
        kruskal = stats.kruskal_wallis({"M1": [1, 1], "M2": [1, 1, 1]})
        # wilcox.test(c(2, 2), c(2, 2, 2))  # W = 3, p-value = NA
        mann_whitney = stats.mann_whitney([2, 2], [2, 2, 2])
        spearman = stats.spearman([1, 1, 1, 1], [1, 2, 3, 4])  # R: NA, "sd is zero"
        flavours = [
            flavour({"M1": [3, 3], "M2": [3, 3, 3], "M3": [3]})
            for flavour in (posthoc.tukey_kramer_ranks, posthoc.dunn_holm, posthoc.tukey_hsd)
        ]
        # friedman.test(matrix(c(1,1,1,2,2,2), ncol = 3, byrow = TRUE))  # NaN, p NA
        friedman = repeated.friedman(pd.DataFrame([[1, 1, 1], [2, 2, 2]]))
    for result in (kruskal, mann_whitney, spearman, friedman):
        assert math.isnan(result.p) and result.note == stats.ALL_EQUAL
    assert mann_whitney.statistic == 3
    for comparison in flavours:
        assert comparison.note == stats.ALL_EQUAL
        assert all(math.isnan(row.p) for row in comparison.rows)
    assert "p < .001" not in kruskal.apa() and "all values equal" in kruskal.apa()


def test_tukey_hsd_with_a_group_of_one_value_matches_r():
    # g <- factor(c("a","b","b","b","c","c","c","c"))
    # v <- c(5, 3.1, 4.2, 3.8, 6.0, 5.5, 6.3, 5.9)
    # TukeyHSD(aov(v ~ g))
    #       diff         lwr            upr            p adj
    # b-a -1.300 -2.935609714373 0.335609714373 0.104938128450
    # c-a  0.925 -0.658672296166 2.508672296166 0.232607581618
    # c-b  2.225  1.143145863452 3.306854136548 0.002629329478
    comparison = posthoc.tukey_hsd({"a": [5.0], "b": [3.1, 4.2, 3.8], "c": [6.0, 5.5, 6.3, 5.9]})
    expected = {
        ("b", "a"): (-1.300, -2.935609714373, 0.335609714373, 0.104938128450),
        ("c", "a"): (0.925, -0.658672296166, 2.508672296166, 0.232607581618),
        ("c", "b"): (2.225, 1.143145863452, 3.306854136548, 0.002629329478),
    }
    for (a, b), (difference, lower, upper, p) in expected.items():
        row = comparison.pair(a, b)
        assert row.difference == pytest.approx(difference, rel=REL)
        assert row.lower == pytest.approx(lower, rel=REL)
        assert row.upper == pytest.approx(upper, rel=REL)
        assert row.p == pytest.approx(p, rel=REL)  # R's ptukey, not scipy's finer integral
    assert "one value" in comparison.note


def test_friedman_and_kendalls_w_match_r():
    # m <- matrix(c(50,75,60, 40,70,70, 55,80,65, 30,60,45, 60,55,70, 45,90,50,
    #               35,65,40, 50,85,75), ncol = 3, byrow = TRUE)
    # friedman.test(m)  # chi-squared = 10.51612903, df = 2, p-value = 0.00520536988
    # d <- data.frame(id = factor(rep(1:8, 3)), model = factor(rep(c("M1","M2","M3"), each = 8)),
    #                 v = c(m[,1], m[,2], m[,3]))
    # rstatix::friedman_effsize(d, v ~ model | id)  # effsize 0.657258064516 (Kendall W)
    result = repeated.friedman(SCORES)
    assert result.statistic == pytest.approx(10.51612903, rel=REL)
    assert result.df == 2
    assert result.p == pytest.approx(0.00520536988, rel=REL)
    assert result.n == 8
    assert result.effect_size == pytest.approx(0.657258064516, rel=REL)


@pytest.mark.parametrize(
    ("a", "b", "v", "p", "n"),
    [
        # wilcox.test(m[,1], m[,2], paired = TRUE)  # V = 1, p = 0.0200852866725 (ties)
        ("M1", "M2", 1.0, 0.0200852866725, 8),
        # wilcox.test(m[,1], m[,3], paired = TRUE)  # V = 0, p = 0.0136766868988 (ties)
        ("M1", "M3", 0.0, 0.0136766868988, 8),
        # wilcox.test(m[,2], m[,3], paired = TRUE)  # V = 24.5, p = 0.0851916964359 (a zero)
        ("M2", "M3", 24.5, 0.0851916964359, 7),
    ],
)
def test_paired_wilcoxon_with_ties_and_zeros_matches_r(a, b, v, p, n):
    result = repeated.paired_wilcoxon(SCORES[a], SCORES[b])
    assert result.statistic == v
    assert result.p == pytest.approx(p, rel=REL)
    assert result.n == n
    assert result.method.startswith("asymptotic")


def test_paired_rank_biserial_with_a_zero_difference_matches_effectsize():
    """The interval's SE counts the non-zero differences, as r does (was [0.1929, 0.9414]).

    effectsize is not in Debian; its published code (R/rank_diff.R,
    ``rank_biserial(Pair(x, y) ~ 1)``) computed by hand in R 4.2:
    d <- m[,2] - m[,3]; nz <- d[d != 0]; r <- rank(abs(nz)) * sign(nz); n <- length(r)
    rb <- (sum(r[r > 0]) + sum(r[r < 0])) / (n * (n + 1) / 2)
    nd <- sum(d != 0); maxw <- (nd^2 + nd) / 2
    se <- sqrt((2 * nd^3 + 3 * nd^2 + nd) / 6) / maxw
    tanh(atanh(rb) + c(-1, 1) * qnorm(0.975) * se)
      # rb 0.75, 95% CI [0.1437172025638, 0.9469292144544]
    """
    result = repeated.paired_wilcoxon(SCORES["M2"], SCORES["M3"])
    assert result.effect_size == pytest.approx(0.75, rel=REL)
    assert result.effect_lower == pytest.approx(0.1437172025638, rel=REL)
    assert result.effect_upper == pytest.approx(0.9469292144544, rel=REL)
    assert result.interval_method == "Fisher z"


def test_an_effect_of_one_says_why_it_has_no_interval():
    """r = 1 printed a bare "1.00"; effectsize's tanh(atanh(1) ± …) is the zero-width [1, 1]."""
    result = repeated.paired_wilcoxon(SCORES["M2"], SCORES["M1"].where(SCORES.index != 4, 55))
    assert result.effect_size == 1.0
    assert math.isnan(result.effect_lower) and math.isnan(result.effect_upper)
    assert result.interval_method.startswith("no CI: r = +1, Fisher's z is infinite")
    from hcss.analysis.tables import effect_cell

    assert effect_cell(result).startswith("1.00 (no CI: r = +1")


def test_spearman_interval_matches_the_bonett_wright_formula_in_r():
    # r <- cor(1:12, c(5,1,4,3,12,2,6,9,7,8,11,10), method = "spearman"); n <- 12
    # tanh(atanh(r) + c(-1, 1) * qnorm(0.975) * sqrt((1 + r^2/2)/(n - 3)))
    #   0.06756904733748 0.90668453923855
    result = stats.spearman(list(range(1, 13)), [5, 1, 4, 3, 12, 2, 6, 9, 7, 8, 11, 10])
    assert result.effect_lower == pytest.approx(0.06756904733748, rel=REL)
    assert result.effect_upper == pytest.approx(0.90668453923855, rel=REL)


def test_bootstrap_statistics_are_the_r_checked_ones_and_intervals_are_seeded():
    """The vectorised ε² and W the bootstrap resamples equal the R-checked tests' values."""
    from hcss.analysis import effect_intervals

    rng = np.random.default_rng(3)
    for _ in range(20):
        blocks = rng.integers(1, 6, size=(7, 3)).astype(float)  # many ties
        if all(len(set(row)) == 1 for row in blocks):
            continue
        w = effect_intervals._kendalls_w(*blocks.T)
        assert w == pytest.approx(repeated.friedman(pd.DataFrame(blocks)).effect_size, rel=1e-12)
        groups = [rng.integers(1, 8, size=size).astype(float) for size in (4, 5, 6)]
        e2 = effect_intervals._epsilon_squared(*groups)
        named = {str(index): group for index, group in enumerate(groups)}
        assert e2 == pytest.approx(stats.kruskal_wallis(named).effect_size, rel=1e-12)
    first = repeated.friedman(SCORES)
    again = repeated.friedman(SCORES)
    assert first.effect_lower <= first.effect_size <= first.effect_upper <= 1
    assert (first.effect_lower, first.effect_upper) == (again.effect_lower, again.effect_upper)
    assert first.interval_method.startswith("percentile bootstrap, 2,000 resamples, seed")


def test_a_degenerate_bootstrap_gives_no_interval_and_no_warning():
    """Interventions, almost all 0, put scipy's "BCa ... cannot be calculated" in a note."""
    from hcss.analysis.effect_intervals import kendalls_w_interval

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        interval = kendalls_w_interval(np.array([[0, 0, 0]] * 9 + [[0, 0, 1]], dtype=float))
    assert interval.missing
    assert interval.method == (
        "no CI: bootstrap degenerate: the resampled statistic is constant or undefined"
    )


def test_paired_wilcoxon_holm_matches_r():
    # p.adjust(c(0.0200852866725, 0.0136766868988, 0.0851916964359), "holm")
    #   0.0410300606965 0.0410300606965 0.0851916964359
    # (rstatix::pairwise_wilcox_test(d, v ~ model, paired = TRUE) prints the same p.adj)
    p = [
        repeated.paired_wilcoxon(SCORES[a], SCORES[b]).p
        for a, b in [("M1", "M2"), ("M1", "M3"), ("M2", "M3")]
    ]
    assert posthoc.holm(p) == pytest.approx(
        [0.0410300606965, 0.0410300606965, 0.0851916964359], rel=REL
    )


def test_holm_leaves_missing_p_out_as_r_does():
    # p.adjust(c(NA, 0.01, 0.02), "holm")  # NA 0.02 0.02 (failed before: NaN counted in m)
    adjusted = posthoc.holm([float("nan"), 0.01, 0.02])
    assert np.isnan(adjusted[0])
    assert adjusted[1:] == pytest.approx([0.02, 0.02], rel=REL)


def test_paired_wilcoxon_exact_and_effect_size_match_r():
    # x <- c(183, 50, 162, 248, 168, 188, 155, 306, 130)
    # y <- c(88, 65, 60, 205, 106, 129, 106, 314, 129)
    # wilcox.test(x, y, paired = TRUE)  # V = 40, p-value = 0.0390625 (exact)
    # dd <- data.frame(id = factor(rep(1:9, 2)), g = factor(rep(c("x","y"), each = 9)), v = c(x, y))
    # effectsize::rank_biserial(x, y, paired = TRUE)  # 0.7777777777778
    #   95% CI [0.2953631293362, 0.9441559019201]
    # (before: rstatix::wilcox_effsize's |z|/√n = 0.691073690719, also labelled "r")
    x = [183, 50, 162, 248, 168, 188, 155, 306, 130]
    y = [88, 65, 60, 205, 106, 129, 106, 314, 129]
    result = repeated.paired_wilcoxon(x, y)
    assert result.statistic == 40
    assert result.p == pytest.approx(0.0390625, rel=REL)
    assert result.method == "exact"
    assert result.effect_size == pytest.approx(0.7777777777778, rel=REL)
    assert result.effect_lower == pytest.approx(0.2953631293362, rel=REL)
    assert result.effect_upper == pytest.approx(0.9441559019201, rel=REL)
    assert result.effect_name == "matched-pairs rank-biserial r"


def test_paired_wilcoxon_refuses_unequal_lengths():
    with pytest.raises(ValueError, match="same length"):
        repeated.paired_wilcoxon([1, 2, 3], [1, 2])
    assert np.isnan(repeated.paired_wilcoxon([1, 2], [1, 2]).p)
