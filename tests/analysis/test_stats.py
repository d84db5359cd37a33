"""Tests and post-hoc comparisons against R 4.2 reference values.

The fixtures are R's ``airquality`` (Ozone, Month; 153 rows with R's NAs) and
``PlantGrowth``; the golden numbers were computed by R, not by this package.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hcss.analysis import posthoc, stats

FIXTURES = Path(__file__).parent / "fixtures"
REL = 1e-6


@pytest.fixture(scope="module")
def ozone_by_month() -> dict[int, np.ndarray]:
    airquality = pd.read_csv(FIXTURES / "airquality.csv")
    assert len(airquality) == 153
    assert airquality["Ozone"].isna().sum() == 37
    return {month: rows["Ozone"].to_numpy() for month, rows in airquality.groupby("Month")}


@pytest.fixture(scope="module")
def plant_growth() -> dict[str, np.ndarray]:
    plants = pd.read_csv(FIXTURES / "plantgrowth.csv")
    assert len(plants) == 30
    return {group: rows["weight"].to_numpy() for group, rows in plants.groupby("group")}


def test_kruskal_wallis_matches_r(ozone_by_month):
    # kruskal.test(Ozone ~ Month, data = airquality)
    result = stats.kruskal_wallis(ozone_by_month)
    assert result.statistic == pytest.approx(29.26657631, rel=REL)
    assert result.df == 4
    assert result.p == pytest.approx(6.900714119e-06, rel=REL)
    assert result.n == 116  # NAs dropped, as R does
    assert result.effect_size == pytest.approx(29.26657631 / 115, rel=REL)
    assert result.apa() == "χ²(4, N = 116) = 29.27, p < .001, ε² = 0.25"


def test_mann_whitney_matches_r_with_ties(ozone_by_month):
    # wilcox.test(Ozone ~ Month, airquality, subset = Month %in% c(5, 8))
    result = stats.mann_whitney(ozone_by_month[5], ozone_by_month[8])
    assert result.statistic == pytest.approx(127.5, rel=REL)
    assert result.p == pytest.approx(1.208078308e-04, rel=REL)
    assert result.method == "asymptotic, continuity=True (ties: no exact p)"
    # rank-biserial r = 2U/(n1 n2) - 1 with n1 = n2 = 26; effectsize 0.8.3:
    # a <- airquality[airquality$Month %in% c(5, 8), ]
    # rank_biserial(Ozone ~ Month, data = a)  # -0.6227810650888 [-0.7803966500989, -0.3907515176515]
    assert result.effect_size == pytest.approx(2 * 127.5 / 676 - 1, rel=REL)
    assert result.effect_size == pytest.approx(-0.6227810650888, rel=REL)
    assert result.effect_lower == pytest.approx(-0.7803966500989, rel=REL)
    assert result.effect_upper == pytest.approx(-0.3907515176515, rel=REL)
    assert result.effect_name == "rank-biserial r" and result.interval_method == "Fisher z"


def test_mann_whitney_without_continuity_is_smaller_p(ozone_by_month):
    corrected = stats.mann_whitney(ozone_by_month[5], ozone_by_month[8])
    plain = stats.mann_whitney(ozone_by_month[5], ozone_by_month[8], continuity=False)
    assert plain.p < corrected.p


def test_mann_whitney_exact_without_ties_by_hand():
    # x entirely below y, n1 = n2 = 3: U = 0 and the exact two-sided p is
    # 2 * (1 / C(6, 3)) = 0.1, as R's wilcox.test(c(1,2,3), c(4,5,6)) gives.
    result = stats.mann_whitney([1, 2, 3], [4, 5, 6])
    assert result.method == "exact"
    assert result.statistic == 0
    assert result.p == pytest.approx(0.1, rel=REL)
    assert result.effect_size == -1.0


def test_tukey_hsd_matches_r(plant_growth):
    # TukeyHSD(aov(weight ~ group, data = PlantGrowth))
    comparison = posthoc.tukey_hsd(plant_growth)
    trt1_ctrl = comparison.pair("trt1", "ctrl")
    assert trt1_ctrl.difference == pytest.approx(-0.371, rel=REL)
    assert trt1_ctrl.lower == pytest.approx(-1.0622160514, rel=REL)
    assert trt1_ctrl.upper == pytest.approx(0.3202160514, rel=REL)
    assert trt1_ctrl.p == pytest.approx(0.3908711442, rel=REL)
    trt2_ctrl = comparison.pair("trt2", "ctrl")
    assert trt2_ctrl.difference == pytest.approx(0.494, rel=REL)
    assert trt2_ctrl.p == pytest.approx(0.1979959913, rel=REL)
    trt2_trt1 = comparison.pair("trt2", "trt1")
    assert trt2_trt1.difference == pytest.approx(0.865, rel=REL)
    assert trt2_trt1.p == pytest.approx(0.01200642398, rel=REL)


@pytest.mark.parametrize(
    ("first", "second", "difference", "p"),
    [
        (5, 7, -41.21153846, 9.66888077e-05),
        (5, 8, -38.53846154, 3.455526019e-04),
        (7, 9, 29.21419098, 0.01133156585),
        (6, 9, 0.03256704981, 1.0),
    ],
)
def test_tukey_kramer_on_mean_ranks_matches_reference(ozone_by_month, first, second, difference, p):
    row = posthoc.tukey_kramer_ranks(ozone_by_month).pair(first, second)
    assert row.difference == pytest.approx(difference, rel=REL)
    assert row.p == pytest.approx(p, rel=REL)
    assert row.lower < row.difference < row.upper


def test_rank_variance_by_hand():
    # ranks of (1, 2, 2, 3): N = 4, one tie of 2: 4*5/12 - (8 - 2)/(12*3) = 5/3 - 1/6
    assert posthoc.rank_variance(np.array([1.0, 2.0, 2.0, 3.0])) == pytest.approx(1.5)


def test_dunn_holm_cross_checked_by_hand(ozone_by_month):
    """scikit-posthocs' Holm-adjusted p against z computed from the rank formula."""
    from scipy.stats import norm
    from statsmodels.stats.multitest import multipletests

    comparison = posthoc.dunn_holm(ozone_by_month)
    assert len(comparison.rows) == 10
    pooled = np.concatenate([v[~np.isnan(v)] for v in ozone_by_month.values()])
    ranks = pd.Series(pooled).rank().to_numpy()
    sizes = {m: int((~np.isnan(v)).sum()) for m, v in ozone_by_month.items()}
    starts = np.cumsum([0, *sizes.values()])
    mean_rank = {m: ranks[starts[i] : starts[i + 1]].mean() for i, m in enumerate(sizes)}
    n = len(pooled)
    _, ties = np.unique(pooled, return_counts=True)
    variance = n * (n + 1) / 12 - (ties**3 - ties).sum() / (12 * (n - 1))
    raw = []
    for row in comparison.rows:
        se = np.sqrt(variance * (1 / sizes[row.group_a] + 1 / sizes[row.group_b]))
        z = (mean_rank[row.group_a] - mean_rank[row.group_b]) / se
        assert row.statistic == pytest.approx(z, rel=REL)
        raw.append(2 * norm.sf(abs(z)))
    holm = multipletests(raw, method="holm")[1]
    for row, expected in zip(comparison.rows, holm, strict=True):
        assert row.p == pytest.approx(expected, rel=REL)
    # ... and against scikit-posthocs doing the Holm step itself.
    import scikit_posthocs

    long = pd.DataFrame(
        [(value, month) for month, values in ozone_by_month.items() for value in values],
        columns=["Ozone", "Month"],
    ).dropna()
    matrix = scikit_posthocs.posthoc_dunn(long, val_col="Ozone", group_col="Month", p_adjust="holm")
    for row in comparison.rows:
        assert row.p == pytest.approx(matrix.loc[row.group_a, row.group_b], rel=REL)
    # The mean-rank difference is the same quantity the R reference gives.
    assert comparison.pair(5, 7).difference == pytest.approx(-41.21153846, rel=REL)


def test_spearman_by_hand():
    x = [1, 2, 3, 4, 5, 6]
    y = [2, 1, 4, 3, 6, 5]
    # no ties: rho = 1 - 6 sum(d^2) / (n (n^2 - 1)), d = (-1, 1, -1, 1, -1, 1)
    rho = 1 - 6 * 6 / (6 * 35)
    result = stats.spearman(x, y)
    assert result.statistic == pytest.approx(rho, rel=REL)
    assert result.df == 4
    # n = 6 without ties: R's exact p (cor.test(1:6, c(2,1,4,3,6,5), method = "spearman")
    # gives p = 0.0583333333333), i.e. 2 * #{permutations with S <= 6} / 6! = 2 * 21 / 720
    assert result.p == pytest.approx(2 * 21 / 720, rel=REL)


def test_spearman_drops_incomplete_pairs_and_gives_nan_for_constants():
    result = stats.spearman([1, 2, np.nan, 4, 5], [1, 2, 3, 4, 6])
    assert result.n == 4
    assert result.statistic == pytest.approx(1.0)
    # cor.test(c(1,2,4,5), c(1,1,1,1), method = "spearman")$p.value  # NA (sd is zero)
    constant = stats.spearman([1, 1, 1, 1], [1, 2, 3, 4])
    assert np.isnan(constant.p) and constant.note == "all values equal"


def test_kruskal_wallis_needs_two_groups():
    with pytest.raises(ValueError, match="two groups"):
        stats.kruskal_wallis({"M1": [1.0, 2.0], "M2": []})


def test_holm_by_hand():
    # m = 4: sorted p (.01, .02, .04, .6) times (4, 3, 2, 1) = (.04, .06, .08, .6), already monotone
    adjusted = posthoc.holm([0.04, 0.01, 0.6, 0.02])
    assert adjusted == pytest.approx([0.08, 0.04, 0.6, 0.06])
    assert posthoc.holm([0.5, 0.6]) == pytest.approx([1.0, 1.0])


def test_tukey_hsd_q_is_consistent_with_its_p(plant_growth):
    """q from the interval formula gives the p back through scipy's independent
    studentized range (k = 3, df = 27); R's ptukey and scipy agree to 1e-5 here."""
    from scipy.stats import studentized_range

    for row in posthoc.tukey_hsd(plant_growth).rows:
        assert studentized_range.sf(abs(row.statistic), 3, 27) == pytest.approx(row.p, rel=1e-5)


@pytest.mark.parametrize(
    ("q", "groups", "df", "expected"),
    [
        # options(digits = 17); ptukey(3.5, 3, 5)  # 0.880727057619895
        (3.5, 3, 5, 0.880727057619895),
        # ptukey(1.2, 3, 27)  # 0.32336716585082398
        (1.2, 3, 27, 0.32336716585082398),
        # ptukey(2.0, 5, 100)  # 0.37996598332546166 (half-unit intervals)
        (2.0, 5, 100, 0.37996598332546166),
        # ptukey(3.0, 4, 500)  # 0.8522863948802194
        (3.0, 4, 500, 0.8522863948802194),
        # ptukey(3.3, 3, 30000)  # 0.94868909358101372 (df > 25000: range only)
        (3.3, 3, 30000, 0.94868909358101372),
        # ptukey(0.5, 2, 2)  # 0.24254212290936839
        (0.5, 2, 2, 0.24254212290936839),
        # ptukey(6, 10, 12)  # 0.97489137535679427
        (6.0, 10, 12, 0.97489137535679427),
    ],
)
def test_ptukey_is_rs(q, groups, df, expected):
    from hcss.analysis.r_distributions import ptukey

    assert ptukey(q, groups, df) == pytest.approx(expected, rel=1e-12)


def test_qtukey_is_rs():
    from hcss.analysis.r_distributions import qtukey

    # c(qtukey(0.95, 3, 27), qtukey(0.95, 3, 5), qtukey(0.95, 5, 1e6))
    #   3.5064261233926857 4.6017254459428374 3.8576555268516346
    assert qtukey(0.95, 3, 27) == pytest.approx(3.5064261233926857, rel=1e-12)
    assert qtukey(0.95, 3, 5) == pytest.approx(4.6017254459428374, rel=1e-12)
    assert qtukey(0.95, 5, 1e6) == pytest.approx(3.8576555268516346, rel=1e-12)
