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

import numpy as np
import pandas as pd

from hcss.analysis.exact import snapped
from hcss.analysis.load import SIMULATION
from hcss.tablespec.analysis import MEASURES

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

#: The columns of the measures table: its contract's (hcss.tablespec.analysis.MEASURES).
MEASURE_COLUMNS = list(MEASURES.names)


#: Decision measures in the order a unit's rows are listed.
DECISION_MEASURES = ("success_rate", "decision_time_min", "interventions", *REQUEST_KINDS)
TRIAL_KEYS = ["group", "source", "participant", "scenario_id", "trial_id"]


def _with_splits(decisions: pd.DataFrame) -> pd.DataFrame:
    """Every decision under ``overall`` and again under its own difficulty (``split``)."""
    split_order = {name: index for index, name in enumerate(SPLITS)}
    frames = [decisions.assign(split="overall")]
    for difficulty in ("easy", "difficult"):
        frames.append(decisions[decisions["difficulty"] == difficulty].assign(split=difficulty))
    stacked = pd.concat(frames, ignore_index=True)
    return stacked.assign(split_order=stacked["split"].map(split_order))


def trial_measures(decisions: pd.DataFrame) -> pd.DataFrame:
    """Decision measures per trial and split, one column per measure (vectorised over trials).

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

    One groupby over every trial and split: a 100,800-decision table spent
    minutes in a per-trial loop.
    """
    seconds = decisions["decision_time_s"].astype(float)
    minutes = seconds / 60.0
    positive = (minutes > 0).to_numpy()
    columns = {
        "correct": decisions["correct"].fillna(False).astype(bool).to_numpy(dtype=float),
        "timed": seconds.notna().to_numpy(dtype=float),
        "seconds": seconds.fillna(0.0).to_numpy(),
        "interventions": decisions["n_interventions"].astype(float).to_numpy(),
    }
    for measure, column in REQUEST_KINDS.items():
        counts = decisions[column].astype(float).to_numpy()
        with np.errstate(divide="ignore", invalid="ignore"):
            columns[measure] = np.where(positive, counts / minutes.to_numpy(), np.nan)
    frame = decisions[[*TRIAL_KEYS, "difficulty"]].assign(**columns)
    grouped = _with_splits(frame).groupby(
        [*TRIAL_KEYS, "split_order", "split"], sort=True, dropna=False
    )
    sums = grouped[["correct", "timed", "seconds", "interventions"]].sum()
    sizes = grouped.size()
    rates = grouped[list(REQUEST_KINDS)].mean()
    timed = sums["timed"]
    table = pd.DataFrame(
        {
            "success_rate": sums["correct"] / sizes,
            "decision_time_min": (sums["seconds"] / (60.0 * timed)).where(timed > 0),
            "interventions": sums["interventions"],
        }
    ).join(rates)
    return table.reset_index()


def decision_measures(decisions: pd.DataFrame) -> pd.DataFrame:
    """Every decision measure for every unit and split, as a tidy frame.

    Columns: measure, split, group, source, unit, participant, value. For
    simulation units, ``value`` is the mean over the scenario's runs and
    ``participant`` is empty. Each value is snapped to its exact fraction
    (:mod:`hcss.analysis.exact`), so quantities equal in exact arithmetic are
    equal floats and rank tests see the ties of the exact values.
    """
    if decisions.empty:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    trials = trial_measures(decisions)
    trials["unit"] = trials["scenario_id"].where(
        trials["source"] == SIMULATION, trials["participant"]
    )
    per_trial = trials.melt(
        id_vars=[*TRIAL_KEYS, "split_order", "split", "unit"],
        value_vars=list(DECISION_MEASURES),
        var_name="measure",
        value_name="value",
    )
    per_trial["measure_order"] = per_trial["measure"].map(
        {name: index for index, name in enumerate(DECISION_MEASURES)}
    )
    simulated_human_only = (per_trial["source"] == SIMULATION) & per_trial["measure"].isin(
        HUMAN_ONLY
    )
    per_trial = per_trial[~simulated_human_only].dropna(subset=["value"])
    if per_trial.empty:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    per_trial = per_trial.sort_values(
        [*TRIAL_KEYS, "split_order", "measure_order"], kind="stable", na_position="first"
    )
    per_unit = (
        per_trial.groupby(
            MEASURE_COLUMNS[:-1],  # a unit's keys: every column but its value
            sort=False,
            dropna=False,
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
