"""The R script written beside every report, and the decision table it reads.

A reviewer should not have to trust Python: ``analysis.R`` (a package
resource, so it reads as R) reruns every test of the report with R's own
functions, from the CSV files in the report's folder, and writes R's p beside
hcss's in ``r_pvalues.csv`` (and statistics and effect sizes), after
recomputing the measures it can from the export into ``r_measures.csv``.
``model_decisions.csv`` holds the decisions the models were fitted to, with
the counterbalancing columns they used.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import pandas as pd

from hcss.analysis.clustered import human_decisions
from hcss.analysis.tables import write_checked
from hcss.tablespec.analysis import MODEL_DECISIONS as MODEL_DECISIONS_TABLE
from hcss.tablespec.analysis import MRT_SCORES as MRT_SCORES_TABLE

SCRIPT = "analysis.R"
MODEL_DECISIONS = "model_decisions.csv"
MRT_SCORES = "mrt_scores.csv"
#: The columns of model_decisions.csv: its contract's (hcss.tablespec.analysis).
MODEL_COLUMNS = MODEL_DECISIONS_TABLE.names


def write_r_script(
    directory: Path,
    decisions: pd.DataFrame,
    participants: pd.DataFrame,
    scores: pd.DataFrame | None = None,
) -> list[Path]:
    """Write analysis.R, model_decisions.csv (human decisions) and mrt_scores.csv.

    mrt_scores.csv is the export's own MRT rows (total and parts, as
    scored), not hcss's measure, so the script recomputes the MRT score
    from the export and a wrong measure shows in r_measures.csv.
    """
    script = directory / SCRIPT
    script.write_text(files("hcss.analysis").joinpath(SCRIPT).read_text(encoding="utf-8"))
    written = [script]
    human = human_decisions(decisions, participants)
    if not human.empty:
        table = human[[column for column in MODEL_COLUMNS if column in human.columns]].copy()
        table["correct"] = table["correct"].fillna(False).astype(bool).astype(int)
        write_checked(directory / MODEL_DECISIONS, table, MODEL_DECISIONS_TABLE)
        written.append(directory / MODEL_DECISIONS)
    if scores is not None and (scores["instrument"] == "mrt").any():
        mrt = scores.loc[scores["instrument"] == "mrt", list(MRT_SCORES_TABLE.names)]
        if "mrt_score" in participants.columns:  # the stored total, R's last resort as hcss's
            stored = participants[["participant", "mrt_score"]].dropna()
            mrt = pd.concat(
                [
                    mrt,
                    pd.DataFrame(
                        {
                            "participant": stored["participant"].astype(str),
                            "scale": "stored",
                            "score": pd.to_numeric(stored["mrt_score"]),
                        }
                    ),
                ],
                ignore_index=True,
            )
        write_checked(directory / MRT_SCORES, mrt, MRT_SCORES_TABLE)
        written.append(directory / MRT_SCORES)
    return written
