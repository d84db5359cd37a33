"""The public API (long format in, tidy frame out) gives R's numbers; R code beside each value."""

from __future__ import annotations

import pandas as pd
import pytest

import hcss.analysis as analysis
from tests.support.synthetic import SCORES

REL = 1e-6

#: The Friedman example of test_r_agreement (8 participants × 3 models), in long format.
LONG = (
    SCORES.rename_axis("participant")
    .reset_index()
    .melt(id_vars="participant", var_name="model", value_name="score")
)


def test_friedman_and_paired_wilcoxon_from_long_format():
    # m <- matrix(c(50,75,60, 40,70,70, 55,80,65, 30,60,45, 60,55,70, 45,90,50,
    #               35,65,40, 50,85,75), ncol = 3, byrow = TRUE)
    # friedman.test(m)  # chi-squared = 10.51612903, df = 2, p-value = 0.00520536988
    friedman = analysis.friedman(LONG, dv="score", within="model", subject="participant")
    (row,) = friedman.to_dict("records")
    assert row["statistic"] == pytest.approx(10.51612903, rel=REL)
    assert row["p"] == pytest.approx(0.00520536988, rel=REL)
    assert row["effect_name"] == "Kendall's W"
    assert row["effect_lower"] <= row["effect_size"] <= row["effect_upper"]
    # wilcox.test(m[,1], m[,2], paired = TRUE)$p.value  # 0.0200852866725
    # wilcox.test(m[,1], m[,3], paired = TRUE)$p.value  # 0.0136766868988
    # wilcox.test(m[,2], m[,3], paired = TRUE)$p.value  # 0.0851916964359
    # p.adjust(c(0.0200852866725, 0.0136766868988, 0.0851916964359), "holm")
    #   0.0410300606965 0.0410300606965 0.0851916964359
    # effectsize::rank_biserial(m[,2], m[,3], paired = TRUE)  # 0.75 [0.1928996600157, 0.9414395798715]
    pairs = analysis.paired_wilcoxon(LONG, dv="score", within="model", subject="participant")
    assert list(zip(pairs["group_a"], pairs["group_b"], strict=True)) == [
        ("M1", "M2"),
        ("M1", "M3"),
        ("M2", "M3"),
    ]
    assert pairs["p"].tolist() == pytest.approx(
        [0.0200852866725, 0.0136766868988, 0.0851916964359], rel=REL
    )
    assert pairs["p_holm"].tolist() == pytest.approx(
        [0.0410300606965, 0.0410300606965, 0.0851916964359], rel=REL
    )
    last = pairs.iloc[2]
    assert (last["effect_size"], last["effect_lower"], last["effect_upper"]) == pytest.approx(
        (0.75, 0.1437172025638, 0.9469292144544),
        rel=REL,  # test_r_agreement: effectsize by hand
    )


def test_kruskal_and_tukey_hsd_from_long_format():
    # g <- factor(c("a","b","b","b","c","c","c","c")); v <- c(5, 3.1, 4.2, 3.8, 6.0, 5.5, 6.3, 5.9)
    # kruskal.test(v, g)  # chi-squared = 5.83333333333, df = 2, p-value = 0.0541137662228
    # TukeyHSD(aov(v ~ g))  # c-b: diff 2.225, p adj 0.002629329478
    frame = pd.DataFrame(
        {"group": list("abbbcccc"), "value": [5, 3.1, 4.2, 3.8, 6.0, 5.5, 6.3, 5.9]}
    )
    (row,) = analysis.kruskal(frame, dv="value", between="group").to_dict("records")
    assert row["statistic"] == pytest.approx(5.83333333333, rel=REL)
    assert row["p"] == pytest.approx(0.0541137662228, rel=REL)
    assert row["method"] == "χ² approximation (no ties)"
    tukey = analysis.tukey_hsd(frame, dv="value", between="group").set_index(["group_a", "group_b"])
    assert tukey.loc[("b", "c"), "p"] == pytest.approx(0.002629329478, rel=REL)


def test_mann_whitney_and_spearman_from_long_format():
    # wilcox.test(c(1,2,2,3,5), c(3,4,4,5,6))  # W = 4, p = 0.0906883662 (ties: normal)
    frame = pd.DataFrame({"model": ["x"] * 5 + ["y"] * 5, "v": [1, 2, 2, 3, 5, 3, 4, 4, 5, 6]})
    (row,) = analysis.mann_whitney(frame, dv="v", between="model").to_dict("records")
    assert (row["statistic"], row["U"]) == (4, 4)
    assert row["p"] == pytest.approx(0.0906883662, rel=REL)
    assert row["method"] == "asymptotic, continuity=True (ties: no exact p)"
    # cor.test(1:7, c(2,1,4,3,7,5,6), method = "spearman")  # rho 0.821428571429, p 0.034126984127
    pairs = pd.DataFrame({"a": range(1, 8), "b": [2, 1, 4, 3, 7, 5, 6]})
    (row,) = analysis.spearman(pairs, "a", "b").to_dict("records")
    assert row["statistic"] == pytest.approx(0.821428571429, rel=REL)
    assert row["p"] == pytest.approx(0.034126984127, rel=REL)


def test_bad_input_is_a_clear_value_error():
    with pytest.raises(ValueError, match="no column"):
        analysis.kruskal(LONG, dv="time", between="model")
    with pytest.raises(ValueError, match="exactly two levels"):
        analysis.mann_whitney(LONG, dv="score", between="model")
