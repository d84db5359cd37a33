"""Decision-level models honest at every sample size, against geepack, nlme and lme4.

- fewer than 10 participants: no model, listed once with the tests too small to run;
- 10 to 39 participants: the GEE's fully iterated jackknife errors (from
  geepack's own leave-one-out refits) with t on K − p df; the mixed model's t on nlme's
  between/within df;
- a participant variance at the boundary and a fit statsmodels does not
  converge: lme4's answer (the OLS fit, σ² = RSS/(n − p)).

Fixtures (written once; the generator is not needed to read them):
clustered_twelve.csv holds 432 decisions of 12 generated participants
(3 orders, both first sections, a participant effect on success and time);
clustered_boundary.csv is the same with each participant's mean log time
removed, so the REML participant variance is exactly at 0.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest
from scipy import stats

from hcss.analysis.banner import sample_banner
from hcss.analysis.clustered import success_gee, time_mixed_model
from hcss.analysis.load import load_inputs
from hcss.analysis.measures import all_measures
from hcss.analysis.sections import build_sections
from tests.support.synthetic import study_export

FIXTURES = Path(__file__).parent / "fixtures"

# R 4.2.2, Debian r-cran-geepack 1.3.9, r-cran-lme4 1.1-31, nlme (R's recommended package):
# prep <- function(path) {
#   d <- read.csv(path)
#   d$model <- factor(d$model, levels = c("M1","M2","M3"))
#   d$difficulty <- factor(d$difficulty, levels = c("easy","difficult"))
#   d$first_section <- factor(d$first_section, levels = c("easy","difficult"))
#   d[order(d$participant), ]
# }
# d <- prep("tests/analysis/fixtures/clustered_twelve.csv")
# f <- correct ~ model * difficulty + position + first_section
# fit <- function(data, ...) geeglm(f, id = factor(participant), data = data, family = binomial,
#                                   corstr = "exchangeable", ...)
# b <- coef(fit(d)); K <- 12
# loo <- sapply(unique(d$participant), function(q) coef(fit(d[d$participant != q, ])) - b)
# se <- sqrt((K - 1) / K * rowSums(loo^2))   # the jackknife, from geepack's own refits
# cbind(b, se, 2 * pt(-abs(b / se), K - 8))   # beta, SE, p on K - p = 4 df
# fij <- summary(fit(d, std.err = "fij"))$coefficients[, 2]
# fij * sqrt((K - 1) / (K - 10))   # = se to 1e-6: geepack's fij is (K - q)/K, q = 8 + 2
# summary(fit(d))$coefficients[, 2]   # the uncorrected sandwich: M2 0.403417
GEE_JACKKNIFE_R = {
    "M2": (0.1673752240025, 0.4295989488919, 0.7166807978004),
    "M3": (-0.4742085399611, 0.6506562370948, 0.5064933177914),
    "difficult": (-1.431015709253, 0.2860097534837, 0.007472544177938),
    "position": (0.1781785790252, 0.13336368871, 0.2524813490648),
    "difficult first": (0.8116470324324, 0.3743632870625, 0.09601696746744),
    "M2 × difficult": (0.1387875334736, 0.4931495018031, 0.792338735811),
    "M3 × difficult": (0.121150028282, 0.6675587410751, 0.8648142935726),
}
# l <- lme(log(decision_time_s) ~ model * difficulty + position + first_section,
#          random = ~ 1 | participant, data = d, method = "REML")
# summary(l)$tTable   # Value, Std.Error, DF, p-value
LME_R = {
    "M2": (0.2071682375487, 0.07981531812227, 414, 0.009778394267781),
    "M3": (0.1211246799656, 0.08163643421841, 414, 0.1386471345982),
    "difficult": (0.1707129101359, 0.07919897439559, 414, 0.03169894413061),
    "position": (-0.01605211434873, 0.02969961539835, 414, 0.589155157382),
    "difficult first": (-0.02680153423106, 0.132259145451, 10, 0.8434767876532),
    "M2 × difficult": (0.07658039772588, 0.1120042637163, 414, 0.4945297373465),
    "M3 × difficult": (0.03863574078463, 0.1120042637163, 414, 0.730308010095),
}
# b <- prep("tests/analysis/fixtures/clustered_boundary.csv")
# m <- lmer(log(decision_time_s) ~ model * difficulty + position + first_section
#           + (1 | participant), data = b, REML = TRUE)   # "boundary (singular) fit"
# cf <- summary(m)$coefficients
# df <- ifelse(rownames(cf) == "first_sectiondifficult", 10, 414)   # nlme's, as above
# cbind(cf[,1], cf[,2], 2 * pt(-abs(cf[,3]), df))
# as.data.frame(VarCorr(m))$vcov   # 1.36470659663e-17 0.2204692474464
# summary(lm(log(decision_time_s) ~ model * difficulty + position + first_section,
#            data = b))$sigma^2    # 0.2204692474464 = RSS/(n - p)
BOUNDARY_R = {
    "M2": (0.2071373588777, 0.07886593396352, 0.008948139770343),
    "M3": (0.1210796035083, 0.08066538831835, 0.1341150786255),
    "difficult": (0.1707397908258, 0.07825692149836, 0.02968709470634),
    "position": (-0.01605228544985, 0.02934634556188, 0.5846773207421),
    "difficult first": (5.894863044928e-05, 0.04518165469303, 0.9989846587369),
    "M2 × difficult": (0.07656780472957, 0.1106719997325, 0.4894228514317),
    "M3 × difficult": (0.03862309619878, 0.1106719997325, 0.7272764445077),
}


def _read(name: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    frame = pd.read_csv(FIXTURES / name, dtype={"participant": str})
    decisions = frame.assign(source="study", correct=frame["correct"].astype(bool))
    return decisions, frame[["participant", "model_order"]].drop_duplicates()


def _assert_t_terms(model, expected, df, rel: float, rel_p: float) -> None:
    """exp(β) and exp(β ± t₀.₉₇₅(df) SE) from R's β and SE, and R's p."""
    terms = {term.term: term for term in model.terms}
    assert set(terms) == set(expected)
    for name, (beta, error, *rest) in expected.items():
        quantile = stats.t.ppf(0.975, df(name, rest))
        assert terms[name].ratio == pytest.approx(math.exp(beta), rel=rel), name
        assert terms[name].lower == pytest.approx(math.exp(beta - quantile * error), rel=rel)
        assert terms[name].upper == pytest.approx(math.exp(beta + quantile * error), rel=rel)
        assert terms[name].p == pytest.approx(rest[-1], rel=rel_p), name


def test_two_participants_get_no_model_and_one_banner_line(tmp_path: Path):
    """Before, 2 participants got a GEE table (the issue: p < .001 where glmer gave p ≥ .25)."""
    tables = load_inputs([study_export(tmp_path / "export", participants=2)])
    banner = sample_banner(tables)
    assert (
        "Decision-level GEE and mixed model: they need 10 or more participants (2); "
        "the GEE's robust errors and the mixed model's participant variance from fewer "
        "participants are not trustworthy"
    ) in banner.not_run
    model = success_gee(tables.decisions, tables.participants)
    assert model.terms == () and model.too_small
    assert time_mixed_model(tables.decisions, tables.participants).terms == ()
    names = [
        table.name
        for section in build_sections(tables, all_measures(tables))
        for table in section.tables
    ]
    assert "gee_success" not in names and "mixedlm_time" not in names


def test_twelve_participants_get_the_jackknife_and_t_on_k_minus_p_df():
    """At 12 participants M2's SE was the sandwich's 0.403 with Wald z; the jackknife's is 0.430."""
    model = success_gee(*_read("clustered_twelve.csv"))
    assert model.n_participants == 12
    assert model.method == "GEE, logit link, exchangeable, fully iterated jackknife SE, (K − 1)/K"
    assert model.p_method == "t, 4 df (K − p)"
    # leave-one-out refits with their own stopping rule: agreement to 1e-5
    _assert_t_terms(model, GEE_JACKKNIFE_R, lambda name, rest: 4, rel=1e-5, rel_p=1e-4)


def test_twelve_participants_get_nlmes_between_within_df_for_the_mixed_model():
    model = time_mixed_model(*_read("clustered_twelve.csv"))
    assert model.p_method == "t, nlme's between/within df"
    _assert_t_terms(model, LME_R, lambda name, rest: rest[0], rel=1e-6, rel_p=1e-6)
    participant, residual = model.variance
    # as.data.frame(VarCorr(lmer(... + (1 | participant), d)))$vcov
    #   0.04620497182167 0.22580919114414
    assert participant.variance == pytest.approx(0.04620497182167, rel=1e-5)
    assert residual.variance == pytest.approx(0.22580919114414, rel=1e-6)


def test_a_participant_variance_at_zero_is_lme4s_singular_fit():
    """statsmodels did not converge here, and the report said "not fitted"; lme4 fits it."""
    model = time_mixed_model(*_read("clustered_boundary.csv"))
    df = {"difficult first": 10}
    _assert_t_terms(model, BOUNDARY_R, lambda name, rest: df.get(name, 414), rel=1e-9, rel_p=1e-8)
    participant, residual = model.variance
    assert participant.variance == 0.0
    assert residual.variance == pytest.approx(0.2204692474464, rel=1e-12)  # RSS/(n − p)
    assert model.note.startswith("participant variance at the boundary (0): a singular fit")
