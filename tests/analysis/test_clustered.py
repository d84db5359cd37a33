"""Decision-level models with the participant as cluster, against R's geepack and lme4.

The fixture holds 288 decisions of 8 generated participants (3 models × 12
decisions), written once from tests/analysis/synthetic.py (study_export, seed 5).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.clustered import success_gee, time_mixed_model

FIXTURE = Path(__file__).parent / "fixtures" / "clustered_decisions.csv"

# R code (Debian r-cran-geepack 1.3.9, r-cran-lme4), run on the fixture:
# d <- read.csv("tests/analysis/fixtures/clustered_decisions.csv")
# d$model <- factor(d$model, levels = c("M1","M2","M3"))
# d$difficulty <- factor(d$difficulty, levels = c("easy","difficult"))
# d <- d[order(d$participant), ]
# g <- geeglm(correct ~ model * difficulty, id = factor(participant), data = d,
#             family = binomial, corstr = "exchangeable")
# s <- summary(g)$coefficients
# cbind(OR = exp(s[,1]), lower = exp(s[,1] - qnorm(0.975) * s[,2]),
#       upper = exp(s[,1] + qnorm(0.975) * s[,2]), p = s[,4])
GEE_R = {
    "M2": (0.4790124114311, 0.2235097627056, 1.026590013463, 5.84259249233e-02),
    "M3": (1.3603679938325, 0.4752958645963, 3.893577067446, 5.66234068935e-01),
    "difficult": (0.0357867620839, 0.0111625147805, 0.114731524717, 2.11260146044e-08),
    "M2 × difficult": (10.8495701844084, 4.1106839876320, 28.635909143241, 1.47451449883e-06),
    "M3 × difficult": (2.6019515031083, 0.7034093556232, 9.624767669645, 1.51909665918e-01),
}
# m <- lmer(log(decision_time_s) ~ model * difficulty + (1 | participant), data = d, REML = TRUE)
# cf <- summary(m)$coefficients
# cbind(ratio = exp(cf[,1]), lower = exp(cf[,1] - qnorm(0.975) * cf[,2]),
#       upper = exp(cf[,1] + qnorm(0.975) * cf[,2]))
MIXED_R = {
    "M2": (1.676992315239, 1.371251494348, 2.05090257838),
    "M3": (1.428960399410, 1.171731718306, 1.74265814536),
    "difficult": (1.030108080951, 0.841071198375, 1.26163238081),
    "M2 × difficult": (0.948644732257, 0.712437806015, 1.26316545871),
    "M3 × difficult": (0.966524457363, 0.724952022797, 1.28859496533),
}


@pytest.fixture(scope="module")
def decisions() -> pd.DataFrame:
    frame = pd.read_csv(FIXTURE, dtype={"participant": str})
    return frame.assign(source="study", correct=frame["correct"].astype(bool))


def test_gee_odds_ratios_agree_with_geepack(decisions):
    model = success_gee(decisions)
    assert (model.n_decisions, model.n_participants) == (288, 8)
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(GEE_R)
    for name, (ratio, lower, upper, p) in GEE_R.items():
        # iterative fits with different stopping rules: agreement to 1e-5
        assert terms[name].ratio == pytest.approx(ratio, rel=1e-5)
        assert terms[name].lower == pytest.approx(lower, rel=1e-5)
        assert terms[name].upper == pytest.approx(upper, rel=1e-5)
        assert terms[name].p == pytest.approx(p, rel=1e-4)


def test_mixed_model_time_ratios_agree_with_lme4(decisions):
    model = time_mixed_model(decisions)
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(MIXED_R)
    for name, (ratio, lower, upper) in MIXED_R.items():
        assert terms[name].ratio == pytest.approx(ratio, rel=1e-6)  # same REML estimates
        # standard errors differ slightly: the random-intercept variance sits at the
        # boundary (lme4: singular fit; statsmodels says so in the note)
        assert terms[name].lower == pytest.approx(lower, rel=1e-3)
        assert terms[name].upper == pytest.approx(upper, rel=1e-3)
    assert "boundary" in model.note


def test_models_explain_when_they_cannot_fit(decisions):
    one_person = decisions[decisions["participant"] == decisions["participant"].iloc[0]]
    model = success_gee(one_person)
    assert model.terms == () and "two or more participants" in model.note
