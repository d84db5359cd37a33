"""Read exports and simulation decision tables into one tagged set of frames.

The decisions table has identical columns for the simulation-only experiment
and the study export (docs/data-dictionary.md), so both are read by the same
code; each row is tagged with its comparison *group*: ``M1SIM``/``M2SIM`` for
simulation-only runs and ``M1``/``M2``/``M3`` for human-collective teams. All
later steps group by that label and never need to know where a row came from.

Input problems raise :class:`AnalysisInputError`, whose message is written for
the person running ``hcss analyze``; the command turns it into a click error.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

SIMULATION = "simulation"
STUDY = "study"

#: Group labels in display order: simulation-only models first, then teams.
GROUP_ORDER = ("M1SIM", "M2SIM", "M1", "M2", "M3")

#: Columns of the decisions table the analysis reads (a subset of the contract).
DECISION_COLUMNS = (
    "source",
    "model",
    "participant",
    "trial_id",
    "scenario_id",
    "run",
    "collective",
    "decision_index",
    "difficulty",
    "decision_time_s",
    "timed_out",
    "correct",
    "n_requests",
    "n_investigate",
    "n_abandon",
    "n_decide",
    "n_interventions",
)

#: Export tables beside decisions.csv, with the columns the analysis reads.
STUDY_TABLES: dict[str, tuple[str, ...]] = {
    "participants": ("participant", "is_pilot", "is_bot", "is_demo"),
    "requests": ("participant", "trial_id", "model", "kind", "accepted", "intervention"),
    "observations": ("participant", "trial_id", "model", "kind"),
    "probes": ("participant", "trial_id", "model", "level", "correct", "timed_out"),
    "questionnaire_items": ("participant", "instrument", "model", "item", "value"),
    "scores": ("participant", "instrument", "model", "scale", "score"),
    "stage_timings": ("participant", "stage", "entered_at", "submitted_at"),
}

BOOLEAN_COLUMNS = frozenset(
    {"timed_out", "correct", "accepted", "intervention", "is_pilot", "is_bot", "is_demo"}
)
TEXT_COLUMNS = frozenset(
    {"source", "model", "participant", "trial_id", "scenario_id", "collective", "difficulty"}
)


class AnalysisInputError(ValueError):
    """An input the analysis cannot use, explained for the command line."""


@dataclass(frozen=True)
class StudyTables:
    """Every table the analysis reads, already filtered and tagged.

    ``decisions`` always exists; the study-only tables are empty frames (with
    their columns) when no study export was given, so measures that need them
    simply produce no rows.
    """

    decisions: pd.DataFrame
    requests: pd.DataFrame
    observations: pd.DataFrame
    probes: pd.DataFrame
    questionnaire_items: pd.DataFrame
    scores: pd.DataFrame
    participants: pd.DataFrame
    stage_timings: pd.DataFrame

    @property
    def groups(self) -> list[str]:
        """Groups present in the decisions, in display order."""
        present = set(self.decisions["group"])
        return [group for group in GROUP_ORDER if group in present]


def group_label(source: str, model: str) -> str:
    """The comparison group of a decision: simulation models get a SIM suffix."""
    return f"{model}SIM" if source == SIMULATION else model


def parse_bool(column: pd.Series) -> pd.Series:
    """Read the dictionary's `true`/`false` cells; empty stays missing.

    pandas only infers booleans for columns without gaps, and `probes.correct`
    has gaps until a probe is scored, so the mapping is explicit.
    """
    text = column.astype("string").str.strip().str.lower()
    mapped = text.map({"true": True, "false": False, "1": True, "0": False}, na_action="ignore")
    unknown = text.notna() & mapped.isna()
    if unknown.any():
        raise AnalysisInputError(
            f"column {column.name!r} holds {text[unknown].iloc[0]!r}, expected true or false"
        )
    return mapped.astype("boolean")


def _read_csv(path: Path, table: str, required: Sequence[str]) -> pd.DataFrame:
    try:
        frame = pd.read_csv(path, dtype={name: "string" for name in TEXT_COLUMNS})
    except pd.errors.EmptyDataError as error:
        raise AnalysisInputError(f"{path}: the {table} table is empty (no header)") from error
    except (OSError, pd.errors.ParserError, UnicodeDecodeError) as error:
        raise AnalysisInputError(f"{path}: cannot read the {table} table: {error}") from error
    missing = [name for name in required if name not in frame.columns]
    if missing:
        raise AnalysisInputError(f"{path}: the {table} table lacks column(s) {', '.join(missing)}")
    for name in BOOLEAN_COLUMNS.intersection(frame.columns):
        try:
            frame[name] = parse_bool(frame[name])
        except AnalysisInputError as error:
            raise AnalysisInputError(f"{path}: {error}") from error
    return frame


def _read_decisions(path: Path) -> pd.DataFrame:
    decisions = _read_csv(path, "decisions", DECISION_COLUMNS)
    if decisions.empty:
        raise AnalysisInputError(f"{path}: the decisions table has no rows")
    sources = set(decisions["source"].dropna())
    unknown = sources - {SIMULATION, STUDY}
    if unknown or decisions["source"].isna().any():
        raise AnalysisInputError(
            f"{path}: source must be 'simulation' or 'study', found {sorted(unknown) or 'empty'}"
        )
    difficulties = set(decisions["difficulty"].dropna()) - {"easy", "difficult"}
    if difficulties:
        raise AnalysisInputError(
            f"{path}: difficulty must be 'easy' or 'difficult', found {sorted(difficulties)}"
        )
    decisions["participant"] = decisions["participant"].fillna("")
    decisions["group"] = [
        group_label(source, model)
        for source, model in zip(decisions["source"], decisions["model"], strict=True)
    ]
    unknown_groups = set(decisions["group"]) - set(GROUP_ORDER)
    if unknown_groups:
        raise AnalysisInputError(f"{path}: unknown model(s) {sorted(unknown_groups)}")
    decisions["input"] = str(path)
    return decisions


def _empty(table: str) -> pd.DataFrame:
    return pd.DataFrame({name: pd.Series(dtype="object") for name in STUDY_TABLES[table]})


def _read_input(path: Path) -> dict[str, pd.DataFrame]:
    """One INPUT: a directory holding decisions.csv (and maybe more), or a CSV file."""
    if path.is_file():
        return {"decisions": _read_decisions(path)}
    if not path.is_dir():
        raise AnalysisInputError(f"{path}: no such file or directory")
    decisions_path = path / "decisions.csv"
    if not decisions_path.is_file():
        raise AnalysisInputError(f"{path}: no decisions.csv in this directory")
    tables = {"decisions": _read_decisions(decisions_path)}
    for table, required in STUDY_TABLES.items():
        table_path = path / f"{table}.csv"
        if table_path.is_file():
            tables[table] = _read_csv(table_path, table, required)
    return tables


def _excluded_participants(participants: pd.DataFrame) -> set[str]:
    """Codes of bot, pilot and demo participants: never part of a real analysis."""
    flags = participants[["is_pilot", "is_bot", "is_demo"]].fillna(False).astype(bool)
    return set(participants.loc[flags.any(axis=1), "participant"].astype(str))


def load_inputs(paths: Iterable[str | Path], include_pilot: bool = False) -> StudyTables:
    """Read and combine every INPUT, tag groups and drop flagged participants.

    Study decisions without a participants table are refused unless
    ``include_pilot`` is set: without it there is no way to tell bots and
    pilots from real participants, and silently analysing them would be worse
    than stopping.
    """
    collected: dict[str, list[pd.DataFrame]] = {"decisions": []}
    for path in map(Path, paths):
        for table, frame in _read_input(path).items():
            collected.setdefault(table, []).append(frame)
    if not collected["decisions"]:
        raise AnalysisInputError("no INPUT given")
    combined = {
        table: pd.concat(collected[table], ignore_index=True)
        if collected.get(table)
        else _empty(table)
        for table in ("decisions", *STUDY_TABLES)
    }
    decisions = combined["decisions"]
    has_study = (decisions["source"] == STUDY).any()
    if has_study and not include_pilot:
        if not collected.get("participants"):
            raise AnalysisInputError(
                "study decisions were given without participants.csv, so bot, pilot and demo "
                "participants cannot be excluded; add the export's participants.csv or pass "
                "--include-pilot"
            )
        excluded = _excluded_participants(combined["participants"])
        for table in combined:
            frame = combined[table]
            if "participant" in frame.columns and len(frame):
                combined[table] = frame[~frame["participant"].astype(str).isin(excluded)]
        if combined["decisions"].empty:
            raise AnalysisInputError(
                "no decisions left after excluding bot, pilot and demo participants; "
                "pass --include-pilot to analyse them"
            )
    for table in STUDY_TABLES:
        frame = combined[table]
        if "model" in frame.columns:
            frame = frame.assign(model=frame["model"].astype("string"))
        combined[table] = frame.reset_index(drop=True)
    combined["decisions"] = combined["decisions"].reset_index(drop=True)
    return StudyTables(**combined)
