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
section the trial started with. p-values are Wald z in both.

A fit is reported only when it is trustworthy: a success outcome without
variation, or a model × difficulty cell where every decision went the same
way (separation: the odds ratio is infinite), is not fitted and says why; a
mixed model that statsmodels reports as not converged shows no numbers.
Optimiser warnings are not printed as captions: the fit's status is.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import statsmodels.api as sm
import statsmodels.formula.api as smf
from scipy import stats

from hcss.analysis.mixed_errors import lme4_covariance, refine_intercept_fit

HUMAN_MODELS = ("M1", "M2", "M3")
DESIGN = "C(model, Treatment('M1')) * C(difficulty, Treatment('easy'))"
ORDER_TERMS = {
    "position": "position",
    "first_section": "C(first_section, Treatment('easy'))",
}
WALD_Z = "Wald z"
Z_975 = float(stats.norm.ppf(0.975))


@dataclass(frozen=True)
class ModelTerm:
    """One coefficient on the ratio scale: exp(β) and its 95% interval."""

    term: str
    ratio: float
    lower: float
    upper: float
    p: float


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


def _ratio_terms(params: pd.Series, errors: pd.Series) -> tuple[ModelTerm, ...]:
    terms = []
    for name in params.index:
        if name == "Intercept" or name.endswith(" Var"):
            continue
        beta, error = float(params[name]), float(errors[name])
        terms.append(
            ModelTerm(
                _term_label(name),
                float(np.exp(beta)),
                float(np.exp(beta - Z_975 * error)),
                float(np.exp(beta + Z_975 * error)),
                float(2 * stats.norm.sf(abs(beta / error))),
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


def _too_small(data: pd.DataFrame) -> str:
    if data["participant"].nunique() < 2 or data["model"].nunique() < 2:
        return "needs two or more participants, models and difficulties"
    if data["difficulty"].nunique() < 2:
        return "needs two or more participants, models and difficulties"
    return ""


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
    decisions: pd.DataFrame, participants: pd.DataFrame | None = None
) -> ClusteredModel:
    """Logistic GEE: correct ~ model × difficulty (+ order), exchangeable within participant."""
    data = human_decisions(decisions, participants)
    data["success"] = data["correct"].fillna(False).astype(bool).astype(float)
    method = "GEE, logit link, exchangeable, robust SE"
    n, clusters = len(data), data["participant"].nunique()
    covariates = _covariates(data)

    def empty(note: str) -> ClusteredModel:
        return ClusteredModel(outcome, method, "odds ratio", n, clusters, (), note)

    outcome = "success"
    reason = _too_small(data) or _separation(data)
    if reason:
        return empty(reason)
    data = data.sort_values("participant", kind="stable")
    model = smf.gee(
        _formula("success", covariates),
        groups="participant",
        data=data,
        family=sm.families.Binomial(),
        cov_struct=sm.cov_struct.Exchangeable(),
    )
    try:
        # ddof_scale=0: the scale and exchangeable correlation estimated as geepack does
        (result, errors), caught = _fitted(lambda: _with_errors(model.fit(ddof_scale=0)))
    except (ValueError, np.linalg.LinAlgError) as error:
        return empty(f"not fitted: {error}")
    if "IterationLimitWarning" in caught:
        return empty("the GEE did not converge: no estimates shown")
    if not np.all(np.isfinite(errors)):
        return empty("robust standard errors undefined: too few participants for the terms")
    terms = _ratio_terms(result.params, errors)
    return ClusteredModel(outcome, method, "odds ratio", n, clusters, terms, covariates=covariates)


def time_mixed_model(
    decisions: pd.DataFrame, participants: pd.DataFrame | None = None
) -> ClusteredModel:
    """Linear mixed model: log(time) ~ model × difficulty (+ order) + (1 | participant)."""
    data = human_decisions(decisions, participants)
    seconds = pd.to_numeric(data["decision_time_s"], errors="coerce")
    data = data[seconds > 0].assign(log_time=np.log(seconds[seconds > 0]))
    method = "MixedLM, random intercept per participant, REML, lme4's standard errors"
    outcome, ratio_name = "log decision time", "time ratio"
    n, clusters = len(data), data["participant"].nunique()
    reason = _too_small(data)
    if reason:
        return ClusteredModel(outcome, method, ratio_name, n, clusters, (), reason)
    covariates = _covariates(data)
    model = smf.mixedlm(_formula("log_time", covariates), data, groups=data["participant"])
    try:
        # BFGS to a tight gradient first: statsmodels' default tolerance leaves the
        # variance estimate ~1e-4 from lme4's optimum; its own retries come second
        result, _ = _fitted(lambda: model.fit(reml=True, method=["bfgs"], gtol=1e-10))
        if not result.converged:
            result, _ = _fitted(lambda: model.fit(reml=True))
    except (ValueError, np.linalg.LinAlgError) as error:
        return ClusteredModel(outcome, method, ratio_name, n, clusters, (), f"not fitted: {error}")
    if not result.converged:
        note = "the REML fit did not converge (statsmodels: converged=False): no estimates shown"
        return ClusteredModel(outcome, method, ratio_name, n, clusters, (), note)
    try:
        refined, _ = _fitted(lambda: refine_intercept_fit(model, result))
        covariance = lme4_covariance(model, refined)
    except (ValueError, np.linalg.LinAlgError) as error:
        return ClusteredModel(outcome, method, ratio_name, n, clusters, (), f"not fitted: {error}")
    errors = pd.Series(np.sqrt(np.diag(covariance)), index=refined.fe_params.index)
    components = (
        VarianceComponent("participant (intercept)", refined.participant_variance),
        VarianceComponent("residual", refined.scale),
    )
    note = ""
    if components and components[0].variance <= 1e-8 * max(components[-1].variance, 1e-300):
        note = "participant variance at the boundary (0): a singular fit, as lme4 would say"
    terms = _ratio_terms(refined.fe_params, errors)
    return ClusteredModel(
        outcome, method, ratio_name, n, clusters, terms, note, WALD_Z, components, covariates
    )
