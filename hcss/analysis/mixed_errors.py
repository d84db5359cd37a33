"""Standard errors of a linear mixed model's fixed effects as lme4 reports them.

statsmodels' ``MixedLMResults.bse`` inverts the Hessian of the (restricted)
likelihood over fixed effects and variance parameters jointly. lme4's
``vcov`` is the covariance of the fixed effects *given* the variance
estimates, (Σᵢ Xᵢ' Vᵢ⁻¹ Xᵢ)⁻¹ with Vᵢ = σ² I + Zᵢ G Zᵢ' at the REML
estimates. The two agree on balanced data and drift apart on unbalanced
data (relative differences of 1e-4 and more); a reader comparing with R
expects lme4's, so this computes that formula by hand: statsmodels does not
offer it, and it is a few lines of linear algebra over the model's own
per-participant design matrices.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def lme4_covariance(result: Any) -> np.ndarray:
    """(Σᵢ Xᵢ' Vᵢ⁻¹ Xᵢ)⁻¹ of a fitted statsmodels MixedLM, at its variance estimates."""
    model = result.model
    scale = float(result.scale)
    random_covariance = np.asarray(result.cov_re, dtype=float)
    k = len(result.fe_params)
    information = np.zeros((k, k))
    for fixed, random in zip(model.exog_li, model.exog_re_li, strict=True):
        marginal = scale * np.eye(len(fixed)) + random @ random_covariance @ random.T
        information += fixed.T @ np.linalg.solve(marginal, fixed)
    return np.linalg.inv(information)


def variance_components(result: Any) -> list[tuple[str, float]]:
    """The participant intercept variance and the residual variance, as lme4's VarCorr."""
    random_covariance = np.asarray(result.cov_re, dtype=float)
    return [
        ("participant (intercept)", float(random_covariance[0, 0])),
        ("residual", float(result.scale)),
    ]
