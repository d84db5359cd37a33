"""All measures of a loaded study in one tidy frame, and their display names.

Each measure family lives in its own module (decisions, actions,
instruments); this module only gathers them, so a table builder or a test
can ask for "everything" without knowing where each measure comes from.
"""

from __future__ import annotations

import pandas as pd

from hcss.analysis.action_measures import observation_measures
from hcss.analysis.decision_measures import MEASURE_COLUMNS, decision_measures
from hcss.analysis.instrument_measures import (
    ALL_PARTICIPANTS,
    mrt_scores,
    probe_measures,
    questionnaire_measures,
)
from hcss.analysis.load import STUDY, StudyTables

#: Display names for the fixed measures; questionnaire scales are named
#: from their instrument and scale (see :func:`measure_label`).
MEASURE_LABELS = {
    "success_rate": "Success rate",
    "decision_time_min": "Decision time (min)",
    "request_frequency": "Request frequency (requests/decision/min)",
    "investigate_frequency": "Investigate frequency (requests/decision/min)",
    "abandon_frequency": "Abandon frequency (requests/decision/min)",
    "decide_frequency": "Decide frequency (requests/decision/min)",
    "interventions": "Interventions per participant",
    "collective_observations": "Collective observations (% of actions)",
    "target_observations": "Target observations (% of actions)",
    "sa_overall": "SA probes correct, all levels (%)",
    "sa_level1": "SA probes correct, level 1 perception (%)",
    "sa_level2": "SA probes correct, level 2 comprehension (%)",
    "sa_level3": "SA probes correct, level 3 projection (%)",
    "nasa_tlx.overall": "NASA-TLX: weighted total",
    "nasa_tlx.raw_tlx": "NASA-TLX: raw total",
    "sart.overall": "SART: total SU − (DAR − SAR)",
    "mrt.total": "MRT score: items right over the study's timed parts",
}

INSTRUMENT_LABELS = {
    "nasa_tlx": "NASA-TLX",
    "sart": "SART",
    "post_trial": "Post-trial",
    "ranking": "Post-experiment ranking",
    "mrt": "MRT score",
}

#: The MRT's one measure: the total over the study file's timed parts (the original's two
#: parts of 12 give 0–24; the demo's one part of 4, 0–4), per participant.
MRT_MEASURE = "mrt.total"


def measure_label(measure: str) -> str:
    """Human-readable name of a measure key, e.g. ``nasa_tlx.overall``."""
    if measure in MEASURE_LABELS:
        return MEASURE_LABELS[measure]
    instrument, _, scale = measure.partition(".")
    if instrument in INSTRUMENT_LABELS:
        return f"{INSTRUMENT_LABELS[instrument]}: {scale.replace('_', ' ')}"
    return measure


def measure_order(measure: str) -> tuple[int, str]:
    """Sort key: fixed measures in their listed order, then instruments."""
    fixed = [name for name in MEASURE_LABELS if "." not in name]
    if measure in fixed:
        return (fixed.index(measure), "")
    instrument = measure.partition(".")[0]
    instruments = list(INSTRUMENT_LABELS)
    rank = instruments.index(instrument) if instrument in instruments else len(instruments)
    return (len(fixed) + rank, measure)


def _mrt(tables: StudyTables) -> pd.DataFrame:
    """One MRT row per participant: the total (scores table, else participants.csv)."""
    scores = mrt_scores(tables.scores, tables.participants)
    return pd.DataFrame(
        {
            "measure": MRT_MEASURE,
            "split": "overall",
            "group": ALL_PARTICIPANTS,
            "source": STUDY,
            "unit": scores.index.astype(str),
            "participant": scores.index.astype(str),
            "value": scores.to_numpy(dtype=float),
        },
        columns=MEASURE_COLUMNS,
    )


def all_measures(tables: StudyTables) -> pd.DataFrame:
    """Every measure for every unit, group and split, as one tidy frame."""
    questionnaires = questionnaire_measures(tables.scores, tables.questionnaire_items)
    frames = [
        decision_measures(tables.decisions),
        observation_measures(tables.requests, tables.observations),
        probe_measures(tables.probes),
        questionnaires,
        _mrt(tables),
    ]
    frames = [frame for frame in frames if not frame.empty]
    if not frames:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    combined = pd.concat(frames, ignore_index=True)
    combined["value"] = combined["value"].astype(float)
    return combined.reset_index(drop=True)
