"""The R script written beside every report, and the decision table it reads.

A reviewer should not have to trust Python: ``analysis.R`` (a package
resource, so it reads as R) reruns every test of the report with R's own
functions, from the CSV files in the report's folder, and writes R's p beside
hcss's in ``r_pvalues.csv``. ``model_decisions.csv`` holds the decisions the
models were fitted to, with the counterbalancing columns they used.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

import pandas as pd

from hcss.analysis.clustered import human_decisions

SCRIPT = "analysis.R"
MODEL_DECISIONS = "model_decisions.csv"
MODEL_COLUMNS = (
    "participant",
    "model",
    "difficulty",
    "correct",
    "decision_time_s",
    "position",
    "first_section",
)


def write_r_script(
    directory: Path, decisions: pd.DataFrame, participants: pd.DataFrame
) -> list[Path]:
    """Write analysis.R and, when there are human decisions, model_decisions.csv."""
    script = directory / SCRIPT
    script.write_text(files("hcss.analysis").joinpath(SCRIPT).read_text(encoding="utf-8"))
    written = [script]
    human = human_decisions(decisions, participants)
    if not human.empty:
        table = human[[column for column in MODEL_COLUMNS if column in human.columns]].copy()
        table["correct"] = table["correct"].fillna(False).astype(bool).astype(int)
        table.to_csv(directory / MODEL_DECISIONS, index=False)
        written.append(directory / MODEL_DECISIONS)
    return written
