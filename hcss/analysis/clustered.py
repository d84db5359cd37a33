"""Decision-level models with the participant as a cluster (the repeated-measures design).

Rank tests on per-participant summaries throw away the decisions' detail;
these models keep every decision and account for decisions of one
participant being correlated:

- success (correct or not) by model × difficulty: a logistic GEE with
  exchangeable working correlation within participant (robust sandwich
  errors, as R's geepack), reported as odds ratios with 95% intervals. GEE
  is the primary logistic model because statsmodels' frequentist fit agrees
  with geepack; the subject-specific logistic mixed model (lme4's
  ``glmer``) is in the R script written beside the report, since Python
  offers only a variational Bayes approximation of it;
- decision time by the same design on log seconds: a linear mixed model with
  a random intercept per participant (REML, refined to lme4's optimum),
  reported as time ratios exp(β), with lme4's standard errors
  (:mod:`hcss.analysis.mixed_errors`) and the variance components.

Both models carry the counterbalancing as covariates when it varies: the
trial's position in the participant's order of models (1–3, linear) and the
section the trial started with.

Both are read from participants, not decisions, so they need enough of them:

- fewer than :data:`MIN_PARTICIPANTS` (10) participants, or no more
  participants than coefficients: not fitted, and listed with the tests the
  sample is too small for. A sandwich from 2 clusters for 7 coefficients
  gave p = 1e-27 where lme4's ``glmer`` gave every p ≥ .25;
- from 10 to :data:`SMALL_SAMPLE_PARTICIPANTS` (40) participants, robust
  errors are biased down, so the GEE's are the fully iterated jackknife
  (each participant left out in turn and the GEE refitted; see
  :func:`jackknife_errors` for why not geepack's ``"fij"`` scaling), and its
  p and intervals use Student's t with K − p degrees of freedom (K
  participants, p coefficients); The mixed
  model's p and intervals use t with the between/within degrees of freedom
  R's ``nlme::lme`` gives each term;
- from 40 participants on, the GEE's robust sandwich and Wald z, and the
  mixed model's Wald z, as before.

A fit is reported only when it is trustworthy: a success outcome without
variation, or a model × difficulty cell where every decision went the same
way (separation: the odds ratio is infinite), is not fitted and says why; a
mixed model that statsmodels reports as not converged shows no numbers.
Optimiser warnings are not printed as captions: the fit's status is.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
import pandas as pd
import statsmodels.api as sm
import statsmodels.formula.api as smf
from scipy import stats

from hcss.analysis.cr2 import RobustErrors, cr2_errors
from hcss.analysis.mixed_errors import lme4_covariance, refine_intercept_fit

HUMAN_MODELS = ("M1", "M2", "M3")
DESIGN = "C(model, Treatment('M1')) * C(difficulty, Treatment('easy'))"
ORDER_TERMS = {
    "position": "position",
    "first_section": "C(first_section, Treatment('easy'))",
}
WALD_Z = "Wald z"
Z_975 = float(stats.norm.ppf(0.975))

#: Fewest participants a decision-level model is fitted to.
MIN_PARTICIPANTS = 10
#: Below this many participants the small-sample errors and t degrees of freedom are used.
SMALL_SAMPLE_PARTICIPANTS = 40


@dataclass(frozen=True)
class SampleRules:
    """How many participants a model needs, and below how many its errors are small-sample."""

    min_participants: int = MIN_PARTICIPANTS
    small_sample_below: int = SMALL_SAMPLE_PARTICIPANTS


#: The report's rules; a test of the estimators alone may pass others.
REPORT_RULES = SampleRules()
JACKKNIFE = "fully iterated jackknife SE, (K − 1)/K"


@dataclass(frozen=True)
class ModelTerm:
    """One coefficient on the ratio scale: exp(β) and its 95% interval."""

    term: str
    ratio: float
    lower: float
    upper: float
    p: float
    #: CR2 cluster-robust interval, p and Satterthwaite df (mixed model only; NaN elsewhere)
    robust_lower: float = math.nan
    robust_upper: float = math.nan
    robust_p: float = math.nan
    robust_df: float = math.nan
    #: The smallest ratio the robust t-test detects with 80% power (a ratio above 1; its
    #: inverse below 1 likewise): exp((t₀.₉₇₅ + t₀.₈) · SE) on the robust df
    detectable: float = math.nan


@dataclass(frozen=True)
class VarianceComponent:
    """A variance of the mixed model (participant intercept or residual), on the log scale."""

    name: str
    variance: float

    @property
    def sd(self) -> float:
        return float(np.sqrt(self.variance))


@dataclass(frozen=True)
class ClusteredModel:
    """A fitted decision-level model, or the reason it was not fitted.

    ``terms`` is empty whenever the fit is not reported; ``note`` then says
    why. ``covariates`` names the order terms the model holds.
    """

    outcome: str
    method: str
    ratio_name: str
    n_decisions: int
    n_participants: int
    terms: tuple[ModelTerm, ...]
    note: str = ""
    p_method: str = WALD_Z
    variance: tuple[VarianceComponent, ...] = ()
    covariates: tuple[str, ...] = ()
    #: Why there are no terms is the sample's size (the banner lists the model then).
    too_small: bool = False


def _term_label(term: str) -> str:
    """``C(model, Treatment('M1'))[T.M2]`` → ``M2``; interactions joined with ×."""
    parts = []
    for part in term.split(":"):
        if "[T." in part:
            level = part.split("[T.")[-1].rstrip("]")
            part = f"{level} first" if part.startswith("C(first_section") else level
        parts.append(part)
    return " × ".join(parts)


def _positions(participants: pd.DataFrame | None) -> dict[tuple[str, str], int]:
    """(participant, model) → position of the model in the participant's order, 1-based."""
    if participants is None or "model_order" not in participants.columns:
        return {}
    positions = {}
    for code, order in zip(participants["participant"], participants["model_order"], strict=True):
        if isinstance(order, str):
            for index, model in enumerate(order.split(","), start=1):
                positions[(str(code), model.strip())] = index
    return positions


def human_decisions(
    decisions: pd.DataFrame, participants: pd.DataFrame | None = None
) -> pd.DataFrame:
    """Study decisions of M1–M3 with a participant, plus ``position`` when the order is known."""
    chosen = decisions[
        decisions["source"].eq("study") & decisions["model"].isin(HUMAN_MODELS)
    ].copy()
    chosen = chosen[chosen["participant"].astype(str) != ""]
    chosen["participant"] = chosen["participant"].astype(str)
    chosen["model"] = chosen["model"].astype(str)
    chosen["difficulty"] = chosen["difficulty"].astype(str)
    positions = _positions(participants)
    if positions:
        keys = zip(chosen["participant"], chosen["model"], strict=True)
        chosen["position"] = [positions.get(key, np.nan) for key in keys]
    return chosen


def _covariates(data: pd.DataFrame) -> tuple[str, ...]:
    """Order terms that vary in ``data`` (a constant covariate cannot be estimated)."""
    present = []
    for name in ORDER_TERMS:
        if name in data.columns and data[name].notna().all() and data[name].nunique() > 1:
            present.append(name)
    return tuple(present)


def _formula(outcome: str, covariates: tuple[str, ...]) -> str:
    return " + ".join([f"{outcome} ~ {DESIGN}", *(ORDER_TERMS[name] for name in covariates)])


def _ratio_terms(
    params: pd.Series, errors: pd.Series, df: pd.Series | None = None
) -> tuple[ModelTerm, ...]:
    """exp(β) with its 95% interval and two-sided p: Wald z, or Student's t with ``df[term]``."""
    terms = []
    for name in params.index:
        if name == "Intercept" or name.endswith(" Var"):
            continue
        beta, error = float(params[name]), float(errors[name])
        reference: Any = stats.norm if df is None else stats.t(float(df[name]))
        quantile = float(reference.ppf(0.975))
        terms.append(
            ModelTerm(
                _term_label(name),
                float(np.exp(beta)),
                float(np.exp(beta - quantile * error)),
                float(np.exp(beta + quantile * error)),
                float(2 * reference.sf(abs(beta / error))),
            )
        )
    return tuple(terms)


def _separation(data: pd.DataFrame) -> str:
    """Why a logistic model of ``success`` cannot be estimated, or ``""``."""
    if data["success"].nunique() < 2:
        outcome = "correct" if data["success"].iloc[0] else "incorrect"
        return f"every decision was {outcome}: no variation in success to model"
    cells = data.groupby(["model", "difficulty"])["success"].agg(["mean", "size"])
    for (model, difficulty), cell in cells.iterrows():
        if cell["mean"] in (0.0, 1.0):
            outcome = "correct" if cell["mean"] == 1.0 else "incorrect"
            return (
                f"separation: all {int(cell['size'])} decisions with {model}, {difficulty} were "
                f"{outcome}, so that odds ratio is infinite; not fitted"
            )
    return ""


#: What a model estimates from its participants, and so cannot from too few of them.
FROM_PARTICIPANTS = {
    "gee": "its robust (sandwich) errors from fewer participants are not trustworthy",
    "mixed": "its participant variance and errors from fewer participants are not trustworthy",
}


def too_small_reason(
    participants: int, rules: SampleRules = REPORT_RULES, kind: str = "gee"
) -> str:
    """Why a decision-level model (``kind`` gee or mixed) is not fitted to ``participants``
    clusters, or ``""``."""
    if participants < max(rules.min_participants, 2):
        return (
            f"needs {rules.min_participants} or more participants ({participants}): "
            + FROM_PARTICIPANTS[kind]
        )
    return ""


def _too_small(data: pd.DataFrame, parameters: int, rules: SampleRules, kind: str) -> str:
    clusters = data["participant"].nunique()
    if data["model"].nunique() < 2 or data["difficulty"].nunique() < 2:
        return "needs two or more models and difficulties"
    reason = too_small_reason(clusters, rules, kind)
    small = clusters < rules.small_sample_below
    if not reason and small and clusters <= parameters:
        reason = (
            f"needs more participants ({clusters}) than estimated parameters ({parameters}) "
            "for its small-sample errors and degrees of freedom"
        )
    return reason


def _coefficients(covariates: tuple[str, ...]) -> int:
    """Intercept, 2 model, 1 difficulty, 2 interaction terms, and one per order covariate."""
    return 6 + len(covariates)


def _fitted(fit: Callable[[], Any]) -> tuple[Any, list[str]]:
    """Run ``fit`` with warnings captured (classified by the caller, never printed)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = fit()
    return result, [type(warning.message).__name__ for warning in caught]


def _with_errors(result: Any) -> tuple[Any, pd.Series]:
    """The fit and its standard errors, which statsmodels computes lazily (warnings and all)."""
    return result, result.bse


def success_gee(
    decisions: pd.DataFrame,
    participants: pd.DataFrame | None = None,
    rules: SampleRules = REPORT_RULES,
) -> ClusteredModel:
    """Logistic GEE: correct ~ model × difficulty (+ order), exchangeable within participant."""
    data = human_decisions(decisions, participants)
    data["success"] = data["correct"].fillna(False).astype(bool).astype(float)
    n, clusters = len(data), data["participant"].nunique()
    covariates = _covariates(data)
    small = clusters < rules.small_sample_below
    method = "GEE, logit link, exchangeable, " + (JACKKNIFE if small else "robust SE")
    coefficients = _coefficients(covariates)
    p_method = f"t, {clusters - coefficients} df (K − p)" if small else WALD_Z

    def empty(note: str, too_small: bool = False) -> ClusteredModel:
        return ClusteredModel(
            outcome, method, "odds ratio", n, clusters, (), note, p_method, too_small=too_small
        )

    outcome = "success"
    size = _too_small(data, coefficients, rules, "gee")
    if size:
        return empty(size, too_small=True)
    reason = _separation(data)
    if reason:
        return empty(reason)
    data = data.sort_values("participant", kind="stable")
    formula = _formula("success", covariates)
    try:
        # ddof_scale=0: the scale and exchangeable correlation estimated as geepack does
        (result, errors), caught = _fitted(
            lambda: _with_errors(_gee(formula, data).fit(ddof_scale=0))
        )
    except (ValueError, np.linalg.LinAlgError) as error:
        return empty(f"not fitted: {error}")
    if "IterationLimitWarning" in caught:
        return empty("the GEE did not converge: no estimates shown")
    df = None
    if small:
        try:
            errors = jackknife_errors(formula, data, result.params)
        except (ValueError, np.linalg.LinAlgError) as error:
            return empty(f"jackknife not computed: {error}")
        df = pd.Series(float(clusters - coefficients), index=result.params.index)
    if not np.all(np.isfinite(errors)):
        return empty("robust standard errors undefined: too few participants for the terms")
    terms = _ratio_terms(result.params, errors, df)
    return ClusteredModel(
        outcome, method, "odds ratio", n, clusters, terms, p_method=p_method, covariates=covariates
    )


def _gee(formula: str, data: pd.DataFrame) -> Any:
    return smf.gee(
        formula,
        groups="participant",
        data=data,
        family=sm.families.Binomial(),
        cov_struct=sm.cov_struct.Exchangeable(),
    )


def jackknife_errors(formula: str, data: pd.DataFrame, params: pd.Series) -> pd.Series:
    """The fully iterated jackknife: √(((K − 1)/K) Σᵢ (β₋ᵢ − β)²) per coefficient.

    Each participant is left out in turn and the GEE refitted to convergence
    (correlation and scale re-estimated), starting from the full fit
    (Lipsitz, Laird & Harrington 1990; close to Mancl & DeRouen's
    bias-reduced sandwich). geepack 1.3.9's ``std.err = "fij"`` makes the
    same refits but scales them by (K − q)/K, q counting the coefficients,
    the scale and the correlation; at 12 participants and q = 10 that is 2/11
    of the jackknife, below even the uncorrected sandwich (M2: fij 0.183,
    sandwich 0.403, jackknife 0.430), so hcss keeps (K − 1)/K and is checked
    against geepack's own leave-one-out fits. A refit that does not converge
    or cannot be estimated makes the errors undefined rather than smaller.
    """
    clusters = list(pd.unique(data["participant"]))
    k = len(clusters)
    deviations = []
    for cluster in clusters:
        rest = data[data["participant"] != cluster]
        model = _gee(formula, rest)
        if list(model.exog_names) != list(params.index):
            raise ValueError(f"leaving out {cluster} removes a term of the model")
        refit, caught = _fitted(partial(model.fit, ddof_scale=0, start_params=params.to_numpy()))
        if "IterationLimitWarning" in caught or not np.all(np.isfinite(refit.params)):
            raise ValueError(f"the GEE without participant {cluster} did not converge")
        deviations.append(refit.params.to_numpy() - params.to_numpy())
    spread = np.asarray(deviations)
    variance = (k - 1) / k * (spread**2).sum(axis=0)
    return pd.Series(np.sqrt(variance), index=params.index)


def time_mixed_model(
    decisions: pd.DataFrame,
    participants: pd.DataFrame | None = None,
    rules: SampleRules = REPORT_RULES,
) -> ClusteredModel:
    """Linear mixed model: log(time) ~ model × difficulty (+ order) + (1 | participant).

    The REML optimum is lme4's (:func:`refine_intercept_fit`): statsmodels'
    fit, a bounded search over θ and θ = 0 (the OLS fit) are compared, so a
    fit statsmodels reports as not converged, or one at the boundary, still
    gets lme4's answer. Only when no candidate can be evaluated is the model
    "not fitted".
    """
    data = human_decisions(decisions, participants)
    seconds = pd.to_numeric(data["decision_time_s"], errors="coerce")
    data = data[seconds > 0].assign(log_time=np.log(seconds[seconds > 0]))
    outcome, ratio_name = "log decision time", "time ratio"
    n, clusters = len(data), data["participant"].nunique()
    covariates = _covariates(data)
    small = clusters < rules.small_sample_below
    method = "MixedLM, random intercept per participant, REML (lme4's optimum), lme4's SEs"
    p_method = "t, nlme's between/within df" if small else WALD_Z

    def empty(note: str, too_small: bool = False) -> ClusteredModel:
        return ClusteredModel(
            outcome, method, ratio_name, n, clusters, (), note, p_method, too_small=too_small
        )

    reason = _too_small(data, _coefficients(covariates), rules, "mixed")
    if reason:
        return empty(reason, too_small=True)
    model = smf.mixedlm(_formula("log_time", covariates), data, groups=data["participant"])
    result = None
    try:
        # BFGS to a tight gradient first: statsmodels' default tolerance leaves the
        # variance estimate ~1e-4 from lme4's optimum; its own retries come second
        result, _ = _fitted(lambda: model.fit(reml=True, method=["bfgs"], gtol=1e-10))
        if not result.converged:
            result, _ = _fitted(lambda: model.fit(reml=True))
    except (ValueError, np.linalg.LinAlgError):
        result = None  # the bounded search over θ below does not need statsmodels' optimum
    start = result if result is not None and result.converged else None
    try:
        refined, _ = _fitted(lambda: refine_intercept_fit(model, start))
        covariance = lme4_covariance(model, refined)
    except (ValueError, np.linalg.LinAlgError) as error:
        return empty(f"not fitted: {error}")
    errors = pd.Series(np.sqrt(np.diag(covariance)), index=refined.fe_params.index)
    components = (
        VarianceComponent("participant (intercept)", refined.participant_variance),
        VarianceComponent("residual", refined.scale),
    )
    notes = []
    if refined.participant_variance == 0.0:
        notes.append(
            "participant variance at the boundary (0): a singular fit, as lme4 would say; "
            "the estimates are the OLS fit's, σ² = RSS/(n − p)"
        )
    if start is None:
        notes.append("statsmodels' REML fit did not converge: lme4's optimum by a search over θ")
    df = between_within_df(model) if small else None
    terms = _with_robust(
        _ratio_terms(refined.fe_params, errors, df),
        refined.fe_params,
        cr2_errors(
            model.exog_li,
            model.endog_li,
            refined.fe_params.to_numpy(),
            refined.scale,
            refined.participant_variance,
        ),
    )
    return ClusteredModel(
        outcome,
        method,
        ratio_name,
        n,
        clusters,
        terms,
        "; ".join(notes),
        p_method,
        components,
        covariates,
    )


def _with_robust(
    terms: tuple[ModelTerm, ...], params: pd.Series, robust: RobustErrors
) -> tuple[ModelTerm, ...]:
    """The terms with their CR2 interval, p and Satterthwaite df beside the model-based ones,
    and the smallest ratio the robust test would detect with 80% power."""
    errors = np.sqrt(np.diag(robust.covariance))
    positions = {name: index for index, name in enumerate(params.index)}
    out = []
    names = [n for n in params.index if n != "Intercept" and not n.endswith(" Var")]
    for term, name in zip(terms, names, strict=True):
        index = positions[name]
        df, se, beta = float(robust.df[index]), float(errors[index]), float(params[name])
        critical = float(stats.t.ppf(0.975, df))
        out.append(
            replace(
                term,
                robust_lower=math.exp(beta - critical * se),
                robust_upper=math.exp(beta + critical * se),
                robust_p=float(2 * stats.t.sf(abs(beta / se), df)),
                robust_df=df,
                detectable=math.exp((critical + float(stats.t.ppf(0.8, df))) * se),
            )
        )
    return tuple(out)


def between_within_df(model: Any) -> pd.Series:
    """nlme's denominator degrees of freedom per fixed effect (one grouping level).

    A column constant within every participant is a between-participant term:
    K − 1 − (number of such terms) df. Every other term, the intercept
    included, varies within participants: N − K − (number of within terms).
    """
    names = list(model.exog_names)
    groups = pd.Series(model.groups)
    exog = pd.DataFrame(model.exog, columns=names)
    between = [
        name
        for name in names
        if name != "Intercept"
        and bool((exog[name].groupby(groups.to_numpy()).nunique() <= 1).all())
    ]
    within = [name for name in names if name != "Intercept" and name not in between]
    k, n = groups.nunique(), len(groups)
    df = {name: float(n - k - len(within)) for name in names}
    df.update({name: float(k - 1 - len(between)) for name in between})
    return pd.Series(df)
