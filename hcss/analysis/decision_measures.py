"""Measures computed from the decisions table, one value per analysis unit.

The unit of analysis is what the study treats as one independent
observation:

- a human-collective team's trial: one participant with one model, so the
  unit is the participant code;
- a simulation scenario: each run of a scenario is a trial, the measure is
  computed per run, then averaged over the scenario's runs, so the unit is the
  scenario id. Runs of one scenario share the target layout, so they are
  replicates of one condition, not independent observations.

Every decision-level measure is also computed over only the easy and only the
difficult decisions of a trial (``split``), because the study reports the two
apart: the models differ most on difficult decisions.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pandas as pd

from hcss.analysis.exact import snapped
from hcss.analysis.load import SIMULATION

SPLITS = ("overall", "easy", "difficult")

#: Request kinds with their own frequency measure, and their decisions column.
REQUEST_KINDS = {
    "request_frequency": "n_requests",
    "investigate_frequency": "n_investigate",
    "abandon_frequency": "n_abandon",
    "decide_frequency": "n_decide",
}

#: Measures that only make sense with a human in the loop.
HUMAN_ONLY = frozenset({*REQUEST_KINDS, "interventions"})

MEASURE_COLUMNS = ["measure", "split", "group", "source", "unit", "participant", "value"]


def _split_decisions(decisions: pd.DataFrame) -> Iterator[tuple[str, pd.DataFrame]]:
    """Yield (split name, the decisions in it)."""
    yield "overall", decisions
    for difficulty in ("easy", "difficult"):
        yield difficulty, decisions[decisions["difficulty"] == difficulty]


def trial_measures(decisions: pd.DataFrame) -> dict[str, float]:
    """Decision measures of one trial's decisions (already one split).

    - ``success_rate``: correct decisions / decisions (0–1). Timed-out
      decisions count, as incorrect, since the collective failed to choose.
    - ``decision_time_min``: mean decision time in minutes over the decisions
      with a recorded time, time-outs included at their cap: the seconds are
      summed, then divided once by 60·n, so two trials with the same total
      time give the same number. A decision without a time is left out of
      the mean (counting it as 0 s would shorten the trial); it still counts
      for success.
    - ``request_frequency`` and one per kind: for each decision, its accepted
      requests divided by its decision time in minutes, then averaged over the
      trial's decisions ("requests per decision per minute"). A decision of
      zero length has no rate and is left out of the average.
    - ``interventions``: abandons issued with at least 10% support, summed
      over the trial's decisions (the study reports them per participant, and
      a participant has one trial per model).
    """
    if decisions.empty:
        return {}
    seconds = decisions["decision_time_s"].astype(float)
    timed = seconds.notna()
    minutes = seconds / 60.0
    correct = int(decisions["correct"].fillna(False).astype(bool).sum())
    measures = {
        "success_rate": correct / len(decisions),
        "decision_time_min": (
            float(seconds[timed].sum()) / (60.0 * int(timed.sum())) if timed.any() else np.nan
        ),
        "interventions": float(decisions["n_interventions"].astype(float).sum()),
    }
    positive = minutes > 0
    for measure, column in REQUEST_KINDS.items():
        rates = decisions.loc[positive, column].astype(float) / minutes[positive]
        measures[measure] = float(rates.mean()) if len(rates) else np.nan
    return measures


def decision_measures(decisions: pd.DataFrame) -> pd.DataFrame:
    """Every decision measure for every unit and split, as a tidy frame.

    Columns: measure, split, group, source, unit, participant, value. For
    simulation units, ``value`` is the mean over the scenario's runs and
    ``participant`` is empty. Each value is snapped to its exact fraction
    (:mod:`hcss.analysis.exact`), so quantities equal in exact arithmetic are
    equal floats and rank tests see the ties of the exact values: R's answer
    given the exact values, and R's ``wilcox.test(digits.rank = 7)`` given
    the same doubles (its default ``digits.rank = Inf`` sees no tie between
    doubles that differ in the last bit).
    """
    rows = []
    for (group, source, participant, scenario, trial), trial_decisions in decisions.groupby(
        ["group", "source", "participant", "scenario_id", "trial_id"], sort=True, dropna=False
    ):
        unit = scenario if source == SIMULATION else participant
        for split, split_decisions in _split_decisions(trial_decisions):
            for measure, value in trial_measures(split_decisions).items():
                if source == SIMULATION and measure in HUMAN_ONLY:
                    continue
                rows.append((measure, split, group, source, unit, participant, trial, value))
    per_trial = pd.DataFrame(rows, columns=[*MEASURE_COLUMNS[:-1], "trial_id", "value"]).dropna(
        subset=["value"]
    )
    if per_trial.empty:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    per_unit = (
        per_trial.groupby(
            ["measure", "split", "group", "source", "unit", "participant"], sort=False
        )["value"]
        .mean()
        .reset_index()
    )
    per_unit["value"] = snapped(per_unit["value"])
    return per_unit[MEASURE_COLUMNS]


def unit_table(measures: pd.DataFrame, split: str = "overall") -> pd.DataFrame:
    """One row per unit, one column per measure: what correlations need."""
    chosen = measures[measures["split"] == split]
    return chosen.pivot_table(
        index=["group", "source", "unit", "participant"],
        columns="measure",
        values="value",
        aggfunc="mean",
    ).reset_index()
