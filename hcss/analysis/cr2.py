"""Cluster-robust CR2 errors with Satterthwaite df for the mixed model (Bell–McCaffrey).

The mixed model's own errors hold only if its random intercept is the whole
story: every participant shifted alike, reacting to M2 and M3 alike. CR2 errors
(Bell and McCaffrey 2002; Pustejovsky and Tipton 2018) keep the model's
estimates and its covariance as a working model, but estimate the
coefficients' variance from each participant's residuals, adjusted so that
it is unbiased when the working model is right; the Satterthwaite df then say
how many participants the estimate really rests on (few, where a term varies
within only some of them). This is clubSandwich's ``vcovCR(fit, type = "CR2")``
with ``coef_test(..., test = "Satterthwaite")`` for a model fitted by
inverse-variance weights, the target being the model's own covariance.

For participant j with decisions S_j, working covariance Φ_j = σ²I + τ²11'
(weights W_j = Φ_j⁻¹), M = (Σ X_j'W_jX_j)⁻¹ and marginal residuals e_j:

- D_j upper-triangular with D_j'D_j = Φ_j; B_j = D_j(Φ_j − X_jMX_j')D_j';
  A_j = D_j' B_j^(−1/2) D_j;
- V_CR2 = M [Σ_j X_j'W_jA_j e_j e_j' A_jW_jX_j] M;
- for coefficient c, u_j = (I − H)_j' A_jW_jX_jMc (H = XMX'W) and
  Ω = [u_i'Φu_j]: df = (tr Ω)² / Σ Ω².
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RobustErrors:
    """CR2 covariance of the fixed effects and each coefficient's Satterthwaite df."""

    covariance: np.ndarray
    df: np.ndarray


def _inverse_root(matrix: np.ndarray) -> np.ndarray:
    """B^(−1/2) of a symmetric positive semi-definite B (a Moore–Penrose root on its null
    space, as clubSandwich's matrix_power)."""
    values, vectors = np.linalg.eigh((matrix + matrix.T) / 2)
    tolerance = values.max() * len(values) * np.finfo(float).eps
    root = np.where(values > tolerance, 1.0 / np.sqrt(np.clip(values, tolerance, None)), 0.0)
    inverse_root: np.ndarray = (vectors * root) @ vectors.T
    return inverse_root


def cr2_errors(
    fixed: list[np.ndarray],
    outcome: list[np.ndarray],
    beta: np.ndarray,
    residual_variance: float,
    participant_variance: float,
) -> RobustErrors:
    """CR2 covariance and Satterthwaite df, one design block and outcome per participant."""
    working = [
        residual_variance * np.eye(len(x)) + participant_variance * np.ones((len(x), len(x)))
        for x in fixed
    ]
    weights = [np.linalg.inv(phi) for phi in working]
    bread = np.linalg.inv(sum(x.T @ w @ x for x, w in zip(fixed, weights, strict=True)))
    p = len(beta)
    # E_j = A_j W_j X_j M: what turns a participant's residuals into their share of β's error
    shares = []
    meat = np.zeros((p, p))
    for x, y, w, phi in zip(fixed, outcome, weights, working, strict=True):
        upper = np.linalg.cholesky(phi).T  # D'D = Φ
        b = upper @ (phi - x @ bread @ x.T) @ upper.T
        adjust = upper.T @ _inverse_root(b) @ upper
        share = adjust @ w @ x @ bread
        score = share.T @ (y - x @ beta)
        meat += np.outer(score, score)
        shares.append(share)
    covariance = meat
    df = np.array([_satterthwaite(fixed, weights, working, bread, shares, k) for k in range(p)])
    return RobustErrors(covariance, df)


def _satterthwaite(
    fixed: list[np.ndarray],
    weights: list[np.ndarray],
    working: list[np.ndarray],
    bread: np.ndarray,
    shares: list[np.ndarray],
    coefficient: int,
) -> float:
    """(tr Ω)² / Σ Ω² for one coefficient, with Ω = [u_i'Φu_j] (module docstring)."""
    sizes = [len(x) for x in fixed]
    starts = np.concatenate([[0], np.cumsum(sizes)])
    weighted_design = np.vstack([w @ x for w, x in zip(weights, fixed, strict=True)])  # WX
    columns = []
    for j, (x, share) in enumerate(zip(fixed, shares, strict=True)):
        v = share[:, coefficient]
        u = -weighted_design @ (bread @ (x.T @ v))  # −(XMX'W)_j' v = −W X M X_j' v
        u[starts[j] : starts[j + 1]] += v
        columns.append(u)
    spread = np.column_stack(columns)  # N × K
    phi_spread = np.vstack(
        [phi @ spread[starts[j] : starts[j + 1]] for j, phi in enumerate(working)]
    )
    omega = spread.T @ phi_spread
    return float(np.trace(omega) ** 2 / np.sum(omega * omega))
