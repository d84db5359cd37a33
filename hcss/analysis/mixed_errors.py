"""A random-intercept REML fit refined to lme4's optimum, and lme4's standard errors.

Two differences from statsmodels' ``MixedLM.fit`` matter to a reader who
checks the numbers in R:

- the optimum: near a small participant variance the REML surface is flat,
  and statsmodels' gradient optimisers stop where the gradient is small,
  leaving the variance ~10% and p-values ~1e-4 from lme4's. With one random
  intercept the profiled REML likelihood is a function of one ratio
  θ = σ_participant / σ_residual, so :func:`refine_intercept_fit` maximises
  it with a bounded scalar search (statsmodels computes the likelihood;
  scipy searches) and keeps whichever optimum is higher;
- the standard errors: statsmodels' ``bse`` inverts the joint Hessian over
  fixed effects and variance parameters, while lme4's ``vcov`` is the
  covariance of the fixed effects given the variance estimates,
  (Σᵢ Xᵢ' Vᵢ⁻¹ Xᵢ)⁻¹ with Vᵢ = σ² I + Zᵢ G Zᵢ'. statsmodels does not offer
  that formula, so :func:`lme4_covariance` computes it over the model's own
  per-participant design matrices.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy.optimize import minimize_scalar
from statsmodels.regression.mixed_linear_model import MixedLMParams

#: Upper bound of the search for θ = σ_participant / σ_residual.
MAX_RATIO = 100.0


@dataclass(frozen=True)
class InterceptFit:
    """Fixed effects, residual variance and participant variance at the REML optimum."""

    fe_params: pd.Series
    scale: float
    participant_variance: float


def _profiled_deviance(model: Any, ratio: float) -> float:
    parameters = MixedLMParams.from_components(cov_re=np.array([[ratio * ratio]]))
    return -float(model.loglike(parameters, profile_fe=True))


def refine_intercept_fit(model: Any, result: Any) -> InterceptFit:
    """The better of statsmodels' optimum and a bounded search over θ (random intercept only)."""
    fitted_ratio = float(np.sqrt(max(float(result.cov_re.iloc[0, 0]), 0.0) / result.scale))
    search = minimize_scalar(
        lambda ratio: _profiled_deviance(model, ratio),
        bounds=(0.0, MAX_RATIO),
        method="bounded",
        options={"xatol": 1e-12},
    )
    ratio = fitted_ratio
    if search.success and search.fun < _profiled_deviance(model, fitted_ratio):
        ratio = float(search.x)
    relative = np.array([[ratio * ratio]])
    fixed, _ = model.get_fe_params(relative, np.array([]))
    scale = float(model.get_scale(fixed, relative, np.array([])))
    names = result.fe_params.index
    return InterceptFit(pd.Series(fixed, index=names), scale, ratio * ratio * scale)


def lme4_covariance(model: Any, fit: InterceptFit) -> np.ndarray:
    """(Σᵢ Xᵢ' Vᵢ⁻¹ Xᵢ)⁻¹ at the fit's variance estimates."""
    random_covariance = np.array([[fit.participant_variance]])
    k = len(fit.fe_params)
    information = np.zeros((k, k))
    for fixed, random in zip(model.exog_li, model.exog_re_li, strict=True):
        marginal = fit.scale * np.eye(len(fixed)) + random @ random_covariance @ random.T
        information += fixed.T @ np.linalg.solve(marginal, fixed)
    return np.linalg.inv(information)
