"""Decision-level models with the participant as cluster, against R's geepack and lme4.

The fixture holds 288 decisions of 8 generated participants (3 models × 12
decisions), written once from tests/support/synthetic.py (study_export, seed 5).
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest
from statsmodels.regression.mixed_linear_model import MixedLM

from hcss.analysis.clustered import SampleRules, success_gee, time_mixed_model

#: The estimators alone, as R computes them on these 8 participants: the report's rules
#: (10 participants at least, small-sample errors below 40) are tested in test_small_samples.py.
ASYMPTOTIC = SampleRules(min_participants=2, small_sample_below=0)

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
    model = success_gee(decisions, rules=ASYMPTOTIC)
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
    model = time_mixed_model(decisions, rules=ASYMPTOTIC)
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(MIXED_R)
    for name, (ratio, lower, upper) in MIXED_R.items():
        assert terms[name].ratio == pytest.approx(ratio, rel=1e-6)  # same REML estimates
        # statsmodels' default fit stopped at a participant variance of 0 and printed
        # "boundary"; lme4 finds 0.005879903 (VarCorr below), and so does hcss now
        assert terms[name].lower == pytest.approx(lower, rel=1e-6)
        assert terms[name].upper == pytest.approx(upper, rel=1e-6)
    # as.data.frame(VarCorr(m))$vcov  # 0.005879903265692 0.2547351791051
    participant, residual = model.variance
    assert participant.variance == pytest.approx(0.005879903265692, rel=1e-5)
    assert residual.variance == pytest.approx(0.2547351791051, rel=1e-6)
    assert model.note == "" and model.p_method == "Wald z"


def test_models_explain_when_they_cannot_fit(decisions):
    one_person = decisions[decisions["participant"] == decisions["participant"].iloc[0]]
    model = success_gee(one_person, rules=ASYMPTOTIC)
    assert model.terms == () and "needs 2 or more participants (1)" in model.note


#: The fixture made unbalanced (every fifth decision dropped), with a participant effect on
#: time and the counterbalancing: model_order M1,M2,M3 or M2,M1,M3, and first_section.
UNBALANCED = Path(__file__).parent / "fixtures" / "clustered_unbalanced.csv"

# R code, on the unbalanced fixture:
# d <- read.csv("tests/analysis/fixtures/clustered_unbalanced.csv")
# d$model <- factor(d$model, levels = c("M1","M2","M3"))
# d$difficulty <- factor(d$difficulty, levels = c("easy","difficult"))
# d$first_section <- factor(d$first_section, levels = c("easy","difficult"))
# d <- d[order(d$participant), ]
# m <- lmer(log(decision_time_s) ~ model * difficulty + position + first_section
#           + (1 | participant), data = d, REML = TRUE)
# cf <- summary(m)$coefficients  # estimate, SE, p = 2 * pnorm(-abs(t))
# as.data.frame(VarCorr(m))$vcov  # 0.1535603948288 0.2701362264281
# g <- geeglm(correct ~ model * difficulty + position + first_section,
#             id = factor(participant), data = d, family = binomial, corstr = "exchangeable")
# summary(g)$coefficients  # estimate, SE, p
MIXED_UNBALANCED_R = {
    "M2": (0.5502876391981, 0.1198437689699, 4.396323698041e-06),
    "M3": (0.505245390314, 0.1791380914, 0.004796021761479),
    "difficult": (0.04599029150183, 0.1197135891294, 0.7008529350621),
    "position": (-0.0500925866837, 0.08386824038717, 0.5503223329891),
    "difficult first": (0.1798446725874, 0.0841561829348, 0.0325951796007),
    "M2 × difficult": (-0.07029661406456, 0.1688665842784, 0.6772015193273),
    "M3 × difficult": (-0.006707540034292, 0.1705196369559, 0.9686226003711),
}
GEE_UNBALANCED_R = {
    "M2": (-0.7991683208434, 0.4376773581675, 0.06786077141725),
    "M3": (-0.05192051305272, 0.7338490444709, 0.9435959745051),
    "difficult": (-3.230132745969, 0.6199423792951, 1.884585467682e-07),
    "position": (0.1435469777958, 0.1891640663038, 0.4479428417925),
    "difficult first": (-0.130136834597, 0.1796564108101, 0.4688416178737),
    "M2 × difficult": (2.583156415127, 0.6564227935856, 8.312668437427e-05),
    "M3 × difficult": (1.327046660037, 0.7231674259805, 0.06649863476484),
}


@pytest.fixture(scope="module")
def unbalanced() -> tuple[pd.DataFrame, pd.DataFrame]:
    frame = pd.read_csv(UNBALANCED, dtype={"participant": str})
    decisions = frame.assign(source="study", correct=frame["correct"].astype(bool))
    participants = frame[["participant", "model_order"]].drop_duplicates()
    return decisions, participants


def _assert_terms(model, expected: dict, rel: float, rel_p: float) -> None:
    """Each term's exp(β) and 95% Wald interval from R's β and SE, and its p."""
    z = 1.959963984540054  # qnorm(0.975)
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(expected)
    for name, (beta, error, p) in expected.items():
        assert terms[name].ratio == pytest.approx(math.exp(beta), rel=rel)
        assert terms[name].lower == pytest.approx(math.exp(beta - z * error), rel=rel)
        assert terms[name].upper == pytest.approx(math.exp(beta + z * error), rel=rel)
        assert terms[name].p == pytest.approx(p, rel=rel_p)


def test_mixed_model_with_order_has_lme4_errors_and_variance_components(unbalanced):
    """statsmodels' joint-Hessian SE of M2 was 0.1198479406; lme4's is 0.1198437690."""
    model = time_mixed_model(*unbalanced, rules=ASYMPTOTIC)
    assert model.covariates == ("position", "first_section")
    assert (model.n_decisions, model.n_participants) == (230, 8)
    _assert_terms(model, MIXED_UNBALANCED_R, rel=1e-7, rel_p=1e-6)
    participant, residual = model.variance
    assert participant.variance == pytest.approx(0.1535603948288, rel=1e-6)
    assert residual.variance == pytest.approx(0.2701362264281, rel=1e-6)


def test_gee_with_order_agrees_with_geepack(unbalanced):
    # iterative fits with different stopping rules: agreement to 1e-5
    _assert_terms(
        success_gee(*unbalanced, rules=ASYMPTOTIC), GEE_UNBALANCED_R, rel=1e-5, rel_p=1e-4
    )


def test_all_correct_or_separated_success_is_not_fitted(decisions):
    """Every decision correct gave odds ratio 1.000 [1.000, 1.000], p = .031 before."""
    model = success_gee(decisions.assign(correct=True), rules=ASYMPTOTIC)
    assert model.terms == ()
    assert model.note == "every decision was correct: no variation in success to model"
    separated = decisions.copy()
    cell = (separated["model"] == "M2") & (separated["difficulty"] == "difficult")
    separated.loc[cell, "correct"] = True
    model = success_gee(separated, rules=ASYMPTOTIC)
    assert model.terms == ()
    assert model.note.startswith("separation: all 50 decisions with M2, difficult were correct")


def test_a_mixed_model_statsmodels_leaves_unconverged_gets_lme4s_optimum(decisions, monkeypatch):
    """A fit statsmodels reports as converged=False was "not fitted"; the θ search finds lme4's.

    statsmodels' fit is cut to one iteration (a real, library-reported
    non-convergence); the profiled REML search over θ does not depend on it.
    """
    fit = MixedLM.fit
    monkeypatch.setattr(MixedLM, "fit", lambda self, **options: fit(self, **options, maxiter=1))
    model = time_mixed_model(decisions, rules=ASYMPTOTIC)
    assert "statsmodels' REML fit did not converge" in model.note
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(MIXED_R)
    for name, (ratio, lower, upper) in MIXED_R.items():
        assert (terms[name].ratio, terms[name].lower, terms[name].upper) == pytest.approx(
            (ratio, lower, upper), rel=1e-6
        )
