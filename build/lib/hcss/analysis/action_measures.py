"""Observation actions as a share of everything an operator did in a trial.

Definition (per trial, i.e. per participant and model):

    collective_observations = 100 * C / (R + O)
    target_observations     = 100 * T / (R + O)

where C and T are the trial's observation actions of kind ``collective`` and
``target``, O = all its observation actions (C + T), and R = all requests the
participant issued in the trial, accepted *or refused*: a refused request is
still an action the operator took, and the study counts actions, not effects.

Why per trial and not per decision: observations are clicks on hubs and
targets that carry no decision index (a target click belongs to no single
collective), so they cannot be attributed to one decision. Numerator and
denominator are both counts over the same trial, so "per decision" would not
change the percentage; it is therefore reported Overall only, with no
Easy/Difficult split. A trial with no actions at all has no percentage.
"""

from __future__ import annotations

import pandas as pd

from hcss.analysis.decision_measures import MEASURE_COLUMNS
from hcss.analysis.load import STUDY

OBSERVATION_KINDS = {"collective_observations": "collective", "target_observations": "target"}
TRIAL_KEY = ["participant", "trial_id", "model"]


def _counts(frame: pd.DataFrame, name: str) -> pd.Series:
    if frame.empty:
        return pd.Series(dtype=float, name=name)
    return frame.groupby(TRIAL_KEY, dropna=False).size().rename(name)


def observation_measures(requests: pd.DataFrame, observations: pd.DataFrame) -> pd.DataFrame:
    """Collective and target observations as percentages of all actions, per trial."""
    parts = [_counts(requests, "requests"), _counts(observations, "observations")]
    for measure, kind in OBSERVATION_KINDS.items():
        parts.append(_counts(observations[observations["kind"] == kind], measure))
    counts = pd.concat(parts, axis=1).fillna(0.0)
    if counts.empty:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    actions = counts["requests"] + counts["observations"]
    rows = []
    for (participant, _trial, model), trial_counts in counts.iterrows():
        total = actions.loc[(participant, _trial, model)]
        if total <= 0:
            continue
        for measure in OBSERVATION_KINDS:
            value = 100.0 * trial_counts[measure] / total
            rows.append((measure, "overall", str(model), STUDY, participant, participant, value))
    return pd.DataFrame(rows, columns=MEASURE_COLUMNS)
