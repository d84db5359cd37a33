"""The study's simulation tables under the study's own unit, beside the study's rows.

The study printed its simulation-only tables per (trial scenario, decision
slot), not per decision or per scenario (`hcss.study_units` states
and computes the rule; spec §10). These tables put a run's numbers in that
layout, with the study's row beside each model's, so a simulation can be
compared with the paper on the paper's terms. The per-decision and
per-scenario tables stay the primary ones for a new study.
"""

from __future__ import annotations

from collections.abc import Iterator

import pandas as pd

from hcss import study_units as su
from hcss.analysis.tables import Table

_DIGITS = {"success_pct": 1, "time_min": 2}
_NAMES = {"success_pct": "paper_units_success", "time_min": "paper_units_time"}


#: The decisions columns the study's unit reads (`hcss.study_units.units`).
UNIT_COLUMNS = (
    "model",
    "scenario_id",
    "run",
    "section",
    "end_s",
    "collective",
    "difficulty",
    "correct",
    "decision_time_s",
)


def simulation_rows(decisions: pd.DataFrame) -> Iterator[dict[str, object]]:
    """The simulation-only decisions (not operated or human ones), one plain row at a time.

    A generator over the columns the unit reads: 100,800 decisions as dicts of every
    column held about 200 MB at once.
    """
    if decisions.empty or "source" not in decisions.columns:
        return
    chosen = decisions.loc[decisions["source"] == "simulation", list(UNIT_COLUMNS)]
    for values in chosen.itertuples(index=False, name=None):
        yield dict(zip(UNIT_COLUMNS, values, strict=True))


def simulation_units(decisions: pd.DataFrame) -> list[su.Unit]:
    """The study's units of the simulation-only decisions; empty without any."""
    return su.units(simulation_rows(decisions))


def paper_unit_tables(decisions: pd.DataFrame, units: list[su.Unit] | None = None) -> list[Table]:
    """Success rate and decision time per unit, per model and split, and the study's rows.

    Empty when the decisions hold no simulation-only rows; ``units`` when already computed.
    """
    units = simulation_units(decisions) if units is None else units
    if not units:
        return []
    summaries = su.summarise(units)
    counts = su.unit_counts(summaries)
    models = sorted({model for model, _, _ in summaries})
    tables = []
    for measure in su.MEASURES:
        display, records = [], []
        for model in models:
            for source, lookup in (("this run", summaries), ("study", su.PUBLISHED)):
                cells = [lookup.get((model, split, measure)) for split in su.SPLITS]
                if source == "study" and not any(cells):
                    continue
                if source == "this run":
                    n_text = " / ".join(str(c.n) if c else "0" for c in cells)
                else:
                    n_text = f"{su.PUBLISHED_UNITS_PER_MODEL_OVERALL} / – / –"
                display.append(
                    (model, source, n_text)
                    + tuple(su.cell_text(c, _DIGITS[measure]) for c in cells)
                )
                for split, cell in zip(su.SPLITS, cells, strict=True):
                    if cell is not None:
                        records.append(
                            {"model": model, "source": source, "split": split, "measure": measure}
                            | {
                                "n": cell.n if source == "this run" else None,
                                "mean": cell.mean,
                                "sd": cell.sd,
                                "median": cell.median,
                                "minimum": cell.minimum,
                                "maximum": cell.maximum,
                            }
                        )
        display.append(
            (
                "both",
                "this run / study",
                f"{counts['overall']} / {counts['easy']} / {counts['difficult']} against "
                f"{su.PUBLISHED_UNITS['overall']} / {su.PUBLISHED_UNITS['easy']} / "
                f"{su.PUBLISHED_UNITS['difficult']}",
                "",
                "",
                "",
            )
        )
        tables.append(
            Table(
                _NAMES[measure],
                f"Simulation-only experiment under the study's unit: "
                f"{su.MEASURE_LABELS[measure]}, mean (SD), median (min/max). {su.UNIT_RULE} "
                "N units: overall / easy / difficult; the study prints N per split for both "
                "models together.",
                ("model", "row", "N units", "overall", "easy", "difficult"),
                tuple(display),
                pd.DataFrame(records),
            )
        )
    return tables
