"""Decision-level models with the participant as a cluster (the repeated-measures design).

Rank tests on per-participant summaries throw away the decisions' detail;
these models keep every decision and account for decisions of one
participant being correlated:

- success (correct or not) by model × difficulty: a logistic GEE with
  exchangeable working correlation within participant (robust sandwich
  errors), reported as odds ratios with 95% intervals;
- decision time by the same design on log seconds: a linear mixed model with
  a random intercept per participant, reported as time ratios exp(β).

Reference levels are M1 and easy, so an odds ratio for ``M2`` reads "M2
versus M1 on easy decisions" and an interaction term reads as the extra
factor on difficult ones. statsmodels does the fitting; convergence warnings
are captured into the result's note instead of the terminal.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
import statsmodels.api as sm
import statsmodels.formula.api as smf

HUMAN_MODELS = ("M1", "M2", "M3")
DESIGN = "C(model, Treatment('M1')) * C(difficulty, Treatment('easy'))"


@dataclass(frozen=True)
class ModelTerm:
    """One coefficient on the ratio scale: exp(β) and its 95% interval."""

    term: str
    ratio: float
    lower: float
    upper: float
    p: float


@dataclass(frozen=True)
class ClusteredModel:
    """A fitted decision-level model, or the reason it could not be fitted."""

    outcome: str
    method: str
    ratio_name: str
    n_decisions: int
    n_participants: int
    terms: tuple[ModelTerm, ...]
    note: str = ""


def _term_label(term: str) -> str:
    """``C(model, Treatment('M1'))[T.M2]`` → ``M2``; interactions joined with ×."""
    parts = []
    for part in term.split(":"):
        parts.append(part.split("[T.")[-1].rstrip("]") if "[T." in part else part)
    return " × ".join(parts)


def _human_decisions(decisions: pd.DataFrame) -> pd.DataFrame:
    chosen = decisions[
        decisions["source"].eq("study") & decisions["model"].isin(HUMAN_MODELS)
    ].copy()
    chosen = chosen[chosen["participant"].astype(str) != ""]
    chosen["model"] = chosen["model"].astype(str)
    chosen["difficulty"] = chosen["difficulty"].astype(str)
    return chosen


def _terms(result) -> tuple[ModelTerm, ...]:
    intervals = result.conf_int()
    terms = []
    for name in result.params.index:
        if name in ("Intercept", "Group Var") or name.endswith(" Var"):
            continue
        terms.append(
            ModelTerm(
                _term_label(name),
                float(np.exp(result.params[name])),
                float(np.exp(intervals.loc[name, 0])),
                float(np.exp(intervals.loc[name, 1])),
                float(result.pvalues[name]),
            )
        )
    return tuple(terms)


def _fit(outcome, method, ratio_name, data, fit) -> ClusteredModel:
    n, clusters = len(data), data["participant"].nunique()
    if clusters < 2 or data["model"].nunique() < 2 or data["difficulty"].nunique() < 2:
        return ClusteredModel(
            outcome,
            method,
            ratio_name,
            n,
            clusters,
            (),
            "needs two or more participants, models and difficulties",
        )
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            result = fit(data)
            terms = _terms(result)  # standard errors are computed lazily, warnings and all
        except (ValueError, np.linalg.LinAlgError) as error:
            return ClusteredModel(outcome, method, ratio_name, n, clusters, (), str(error))
    notes = sorted({str(warning.message).split("\n")[0] for warning in caught})
    return ClusteredModel(outcome, method, ratio_name, n, clusters, terms, "; ".join(notes))


def success_gee(decisions: pd.DataFrame) -> ClusteredModel:
    """Logistic GEE: correct ~ model × difficulty, exchangeable within participant."""
    data = _human_decisions(decisions)
    data["success"] = data["correct"].fillna(False).astype(bool).astype(float)

    def fit(frame):
        model = smf.gee(
            f"success ~ {DESIGN}",
            groups="participant",
            data=frame,
            family=sm.families.Binomial(),
            cov_struct=sm.cov_struct.Exchangeable(),
        )
        # ddof_scale=0: the scale and exchangeable correlation estimated as geepack does
        return model.fit(ddof_scale=0)

    return _fit("success", "GEE, logit link, exchangeable, robust SE", "odds ratio", data, fit)


def time_mixed_model(decisions: pd.DataFrame) -> ClusteredModel:
    """Linear mixed model: log(decision time) ~ model × difficulty + (1 | participant)."""
    data = _human_decisions(decisions)
    data = data[data["decision_time_s"].astype(float) > 0]
    data["log_time"] = np.log(data["decision_time_s"].astype(float))

    def fit(frame):
        return smf.mixedlm(f"log_time ~ {DESIGN}", frame, groups=frame["participant"]).fit(
            reml=True
        )

    return _fit(
        "log decision time",
        "MixedLM, random intercept per participant, REML",
        "time ratio",
        data,
        fit,
    )
