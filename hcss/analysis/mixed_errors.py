"""A random-intercept REML fit refined to lme4's optimum, and lme4's standard errors.

Two differences from statsmodels' ``MixedLM.fit`` matter to a reader who
checks the numbers in R:

- the optimum: near a small participant variance the REML surface is flat,
  and statsmodels' gradient optimisers stop where the gradient is small,
  leaving the variance ~10% and p-values ~1e-4 from lme4's. With one random
  intercept the profiled REML likelihood is a function of one ratio
  θ = σ_participant / σ_residual, so :func:`refine_intercept_fit` maximises
  it with a bounded scalar search (the deviance as lme4 defines it; scipy
  searches), evaluates θ = 0 (the OLS fit, σ² = RSS/(n − p)) on its own,
  and keeps whichever optimum is higher;
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

#: Upper bound of the search for θ = σ_participant / σ_residual.
MAX_RATIO = 100.0
#: Deviance differences below this are the optimiser's noise: the boundary θ = 0 is taken
#: then, as lme4 does when its θ lands at ~1e-8 (a participant variance of ~1e-17).
FLAT = 1e-9


@dataclass(frozen=True)
class InterceptFit:
    """Fixed effects, residual variance and participant variance at the REML optimum."""

    fe_params: pd.Series
    scale: float
    participant_variance: float


@dataclass(frozen=True)
class _Groups:
    """Per-participant sums the random-intercept likelihood needs (Vᵢ = I + θ² 11')."""

    exog: np.ndarray  # X, rows in participant order
    endog: np.ndarray  # y
    members: np.ndarray  # each row's participant index
    sizes: np.ndarray  # nᵢ
    cross: np.ndarray  # Σᵢ Xᵢ'Xᵢ
    cross_y: np.ndarray  # Σᵢ Xᵢ'yᵢ
    x_sums: np.ndarray  # rows Xᵢ'1
    y_sums: np.ndarray  # 1'yᵢ


def _groups(model: Any) -> _Groups:
    xs, ys = model.exog_li, model.endog_li
    return _Groups(
        np.vstack(xs),
        np.concatenate(ys),
        np.repeat(np.arange(len(ys)), [len(y) for y in ys]),
        np.array([len(y) for y in ys], dtype=float),
        sum(x.T @ x for x in xs),
        sum(x.T @ y for x, y in zip(xs, ys, strict=True)),
        np.array([x.sum(axis=0) for x in xs]),
        np.array([y.sum() for y in ys]),
    )


def _gls(groups: _Groups, ratio: float) -> tuple[np.ndarray, float, float, float]:
    """β̂, r² = (y − Xβ̂)'V⁻¹(y − Xβ̂), log|V| and log|X'V⁻¹X| at θ = ``ratio``.

    Vᵢ⁻¹ = I − cᵢ 11' with cᵢ = θ² / (1 + nᵢθ²), |Vᵢ| = 1 + nᵢθ²: exact at θ = 0,
    where β̂ is the OLS fit.
    """
    weights = ratio * ratio / (1.0 + groups.sizes * ratio * ratio)
    xvx = groups.cross - (groups.x_sums.T * weights) @ groups.x_sums
    xvy = groups.cross_y - (groups.x_sums.T * weights) @ groups.y_sums
    beta = np.linalg.solve(xvx, xvy)
    errors = (
        groups.endog - groups.exog @ beta
    )  # r² from the residuals, not yV⁻¹y − …: no cancellation
    sums = np.bincount(groups.members, weights=errors, minlength=len(groups.sizes))
    residual = float(errors @ errors) - float((weights * sums**2).sum())
    log_v = float(np.log1p(groups.sizes * ratio * ratio).sum())
    return beta, residual, log_v, float(np.linalg.slogdet(xvx)[1])


def _reml_deviance(groups: _Groups, ratio: float, n: int, p: int) -> float:
    """lme4's profiled REML deviance of a random-intercept model at θ."""
    _, residual, log_v, log_xvx = _gls(groups, ratio)
    dof = n - p
    return log_v + log_xvx + dof * (1.0 + float(np.log(2.0 * np.pi * residual / dof)))


def refine_intercept_fit(model: Any, result: Any | None) -> InterceptFit:
    """lme4's REML optimum over θ ≥ 0 (random intercept only).

    The profiled REML deviance is computed here, as lme4 defines it, so it is
    exact at the boundary θ = 0 (statsmodels' takes log|θ²|, and breaks down
    below θ ≈ 1e-7). Three candidates are compared: statsmodels' optimum
    (``result``, or ``None`` when it did not converge), a bounded search over
    θ, and θ = 0 itself, where β̂ is the OLS fit and σ² = RSS/(n − p), as
    lme4 reports a singular fit. The bounded search never evaluates its end
    points, so θ = 0 is tried on its own.
    """
    groups = _groups(model)
    n, p = int(groups.sizes.sum()), groups.cross.shape[0]

    def deviance(ratio: float) -> float:
        return _reml_deviance(groups, ratio, n, p)

    candidates = [0.0]
    if result is not None:
        candidates.append(float(np.sqrt(max(float(result.cov_re.iloc[0, 0]), 0.0) / result.scale)))
    search = minimize_scalar(
        deviance, bounds=(0.0, MAX_RATIO), method="bounded", options={"xatol": 1e-12}
    )
    if search.success:
        candidates.append(float(search.x))
    deviances = np.array([deviance(ratio) for ratio in candidates])
    if not np.isfinite(deviances).any():
        raise ValueError("the REML likelihood could not be evaluated at any θ")
    best = float(np.nanmin(np.where(np.isfinite(deviances), deviances, np.nan)))
    ratio = 0.0 if deviances[0] <= best + FLAT else candidates[int(np.nanargmin(deviances))]
    beta, residual, _, _ = _gls(groups, ratio)
    scale = residual / (n - p)
    names = list(model.exog_names)
    return InterceptFit(pd.Series(beta, index=names), scale, ratio * ratio * scale)


def lme4_covariance(model: Any, fit: InterceptFit) -> np.ndarray:
    """(Σᵢ Xᵢ' Vᵢ⁻¹ Xᵢ)⁻¹ at the fit's variance estimates."""
    random_covariance = np.array([[fit.participant_variance]])
    k = len(fit.fe_params)
    information = np.zeros((k, k))
    for fixed, random in zip(model.exog_li, model.exog_re_li, strict=True):
        marginal = fit.scale * np.eye(len(fixed)) + random @ random_covariance @ random.T
        information += fixed.T @ np.linalg.solve(marginal, fixed)
    return np.linalg.inv(information)
