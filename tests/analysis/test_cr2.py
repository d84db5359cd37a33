"""The mixed model's CR2 cluster-robust errors and Satterthwaite df, against clubSandwich.

R 4.2.2, Debian r-cran-lme4 1.1-31 and r-cran-clubsandwich 0.5.8:

    library(lme4); library(clubSandwich)
    prep <- function(path) {
      d <- read.csv(path)
      d$model <- factor(d$model, levels = c("M1","M2","M3"))
      d$difficulty <- factor(d$difficulty, levels = c("easy","difficult"))
      d$first_section <- factor(d$first_section, levels = c("easy","difficult"))
      d[order(d$participant), ]
    }
    d <- prep("tests/analysis/fixtures/clustered_twelve.csv")   # or clustered_unbalanced.csv
    m <- lmer(log(decision_time_s) ~ model * difficulty + position + first_section
              + (1 | participant), data = d, REML = TRUE,
              control = lmerControl(optimizer = "bobyqa",
                                    optCtrl = list(rhobeg = 1e-3, rhoend = 1e-12)))
    ct <- coef_test(m, vcov = "CR2", test = "Satterthwaite", cluster = d$participant)
    data.frame(SE = ct$SE, df = ct$df_Satt, p = ct$p_Satt)

Before these columns the report had only the model-based errors, whose t-tests
use nlme's N − K − p df (414 here) for terms that vary within participants.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest
from scipy import stats

from hcss.analysis.clustered import SampleRules, time_mixed_model
from hcss.analysis.design_tables import model_table

FIXTURES = Path(__file__).parent / "fixtures"
ANY_SIZE = SampleRules(min_participants=2, small_sample_below=0)  # CR2 at any size

# term: (SE, Satterthwaite df, p), clubSandwich CR2
CR2_TWELVE = {
    "M2": (0.09710765931074, 10.897912906541, 5.647556902644e-02),
    "M3": (0.09155115582017, 10.174676791605, 2.147880547813e-01),
    "difficult": (0.06735775047327, 11.000000000000, 2.775418725549e-02),
    "position": (0.03823703777374, 8.157594218337, 6.854662267646e-01),
    "difficult first": (0.13225914545103, 10.000000000000, 8.434767876530e-01),
    "M2 × difficult": (0.11420286631970, 11.000000000000, 5.163297586336e-01),
    "M3 × difficult": (0.08857474336125, 11.000000000000, 6.711335638479e-01),
}
CR2_UNBALANCED = {
    "M2": (0.09105060642649, 6.300601826264, 7.741558424079e-04),
    "M3": (0.11835282339173, 5.047412645935, 7.780901003446e-03),
    "difficult": (0.11002453701903, 6.987547724506, 6.884929507800e-01),
    "position": (0.07692527535823, 5.001501785070, 5.436565787916e-01),
    "difficult first": (0.07633673028394, 5.021264311034, 6.486112878814e-02),
    "M2 × difficult": (0.15960375895667, 6.996868702245, 6.729012127724e-01),
    "M3 × difficult": (0.13577164890197, 6.982701540277, 9.619814731645e-01),
}


def _read(name: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    frame = pd.read_csv(FIXTURES / name, dtype={"participant": str})
    decisions = frame.assign(source="study", correct=frame["correct"].astype(bool))
    return decisions, frame[["participant", "model_order"]].drop_duplicates()


@pytest.mark.parametrize(
    ("fixture", "expected"),
    [("clustered_twelve.csv", CR2_TWELVE), ("clustered_unbalanced.csv", CR2_UNBALANCED)],
)
def test_cr2_errors_and_satterthwaite_df_match_club_sandwich(fixture: str, expected: dict):
    model = time_mixed_model(*_read(fixture), rules=ANY_SIZE)
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(expected)
    for name, (error, df, p) in expected.items():
        term = terms[name]
        assert term.robust_df == pytest.approx(df, abs=1e-6), name
        assert term.robust_p == pytest.approx(p, rel=1e-6), name
        quantile = stats.t.ppf(0.975, df)
        assert math.log(term.robust_upper / term.ratio) == pytest.approx(quantile * error, rel=1e-6)
        assert math.log(term.ratio / term.robust_lower) == pytest.approx(quantile * error, rel=1e-6)
        power = quantile + stats.t.ppf(0.8, df)
        assert term.detectable == pytest.approx(math.exp(power * error), rel=1e-6)


def test_the_table_shows_both_errors_and_states_the_random_intercept_assumption():
    model = time_mixed_model(*_read("clustered_twelve.csv"))
    table = model_table("mixedlm_time", model)
    assert table.header[-3:] == (
        "CR2 95% CI",
        "CR2 p (Satterthwaite df)",
        "Detectable ratio (80% power)",
    )
    assert "random intercept only" in table.caption
    assert "every participant shifted alike" in table.caption
    first_section = next(row for row in table.rows if row[0] == "difficult first")
    assert first_section[5] == ".843 (10.0 df)"
    assert set(table.frame.columns) >= {"robust_p", "robust_df", "detectable_ratio"}
