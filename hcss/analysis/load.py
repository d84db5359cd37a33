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
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from hcss.analysis.sources import SourceError, read_tables
from hcss.analysis.studies import (
    StudyFile,
    StudyPoolingError,
    in_study,
    not_completed,
    refuse_pooling,
    set_aside_never_opened,
    study_files,
)
from hcss.tablespec import DECISIONS, EXPORT_TABLES, TableSpec
from hcss.tablespec.frames import ContractError, check

SIMULATION = "simulation"
STUDY = "study"
#: Synthetic participants' trials (`hcss plan`): read as a study's teams, never beside real
#: participants unless asked (`pool_synthetic`).
SYNTHETIC = "synthetic"

#: Group labels in display order: simulation-only models first, then teams.
GROUP_ORDER = ("M1SIM", "M2SIM", "M1", "M2", "M3")

#: The tables of an export the analysis reads, beside decisions.
ANALYSED_TABLES = (
    "participants",
    "requests",
    "observations",
    "probes",
    "questionnaire_items",
    "scores",
    "stage_timings",
)
#: Columns of the decisions table the analysis reads: the contract's required ones.
DECISION_COLUMNS = DECISIONS.required

#: Export tables beside decisions.csv, with the columns the analysis reads.
STUDY_TABLES: dict[str, tuple[str, ...]] = {
    table: EXPORT_TABLES[table].required for table in ANALYSED_TABLES
}

#: The bool and text columns among those read, by their contract's types.
BOOLEAN_COLUMNS = frozenset(
    column.name
    for spec in (DECISIONS, *(EXPORT_TABLES[table] for table in ANALYSED_TABLES))
    for column in spec.columns
    if column.required and column.dtype == "bool"
)
#: Numeric decision columns: a time in seconds and the per-decision counts. None may be
#: negative or infinite; a missing time is allowed (the decision had no recorded end).
NUMERIC_DECISION_COLUMNS = (
    "decision_time_s",
    "n_requests",
    "n_investigate",
    "n_abandon",
    "n_decide",
    "n_interventions",
)
#: The longest plausible decision, in seconds: a decision cannot outlast its trial, and the
#: bundled study's trials are 20 min and the simulation's decisions time out at 30 min.
MAX_DECISION_S = 3600.0
#: Per-decision counts are whole numbers; no decision of a trial can hold more than this.
MAX_COUNT = 100_000
#: Plausible (lowest, highest, whole) per numeric decision column.
DECISION_RANGES: dict[str, tuple[float, float, bool]] = {
    "decision_time_s": (0.0, MAX_DECISION_S, False),
    **{
        name: (0.0, float(MAX_COUNT), True)
        for name in ("n_requests", "n_investigate", "n_abandon", "n_decide", "n_interventions")
    },
}
TEXT_COLUMNS = frozenset(
    column.name for column in DECISIONS.columns if column.required and column.dtype == "str"
)


class AnalysisInputError(ValueError):
    """An input the analysis cannot use, explained for the command line."""


@dataclass(frozen=True)
class InputSummary:
    """One INPUT and how many rows of each table it gave after exclusions."""

    path: str
    table_rows: tuple[tuple[str, int], ...]

    @property
    def rows(self) -> int:
        return sum(count for _, count in self.table_rows)


@dataclass(frozen=True)
class StudyTables:
    """Every table the analysis reads, already filtered and tagged.

    Every table exists; a table no INPUT held is an empty frame with its
    columns, so measures that need it simply produce no rows (an export whose
    trials have no decisions still gives its questionnaires and probes).
    ``all_participants`` is the participants table before exclusions (the
    report's sample and attrition count the excluded too); every table has an
    ``input`` column naming the INPUT a row came from.
    """

    decisions: pd.DataFrame
    requests: pd.DataFrame
    observations: pd.DataFrame
    probes: pd.DataFrame
    questionnaire_items: pd.DataFrame
    scores: pd.DataFrame
    participants: pd.DataFrame
    stage_timings: pd.DataFrame
    all_participants: pd.DataFrame = field(default_factory=pd.DataFrame)
    inputs: tuple[InputSummary, ...] = ()
    warnings: tuple[str, ...] = ()
    studies: tuple[StudyFile, ...] = ()  # the study files of the analysed participants
    never_opened: int = 0  # links in the inputs nobody opened (set aside, not participants)
    partial: int = 0  # analysed participants who did not complete (their partial data are in)
    completers_only: bool = False
    left_out_partial: int = 0  # with completers_only: the participants it left out

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


def _delimiter_hint(frame: pd.DataFrame) -> str:
    """Why every column seems missing, when the file is not comma-separated."""
    if len(frame.columns) != 1:
        return ""
    header = str(frame.columns[0])
    for delimiter, name in ((";", "semicolons"), ("\t", "tabs"), ("|", "bars")):
        if delimiter in header:
            return (
                f"; its header is one column separated by {name} ({header[:60]!r}): "
                "the export's tables are comma-separated CSV (a spreadsheet saving in a "
                "locale with decimal commas writes semicolons; save as CSV with commas)"
            )
    return ""


def _checked(frame: pd.DataFrame, where: str, table: str, required: Sequence[str]) -> pd.DataFrame:
    """The raw table with its required columns present and booleans parsed."""
    missing = [name for name in required if name not in frame.columns]
    if missing:
        raise AnalysisInputError(
            f"{where}: the {table} table lacks column(s) {', '.join(missing)}"
            + _delimiter_hint(frame)
        )
    for name in BOOLEAN_COLUMNS.intersection(frame.columns):
        try:
            frame[name] = parse_bool(frame[name])
        except AnalysisInputError as error:
            raise AnalysisInputError(f"{where}: {error}") from error
    return frame


def _keeps_contract(frame: pd.DataFrame, where: str, spec: TableSpec) -> None:
    """Refuse a table whose read columns break the dictionary: a value of the wrong type,
    or an empty cell where the dictionary allows none (hcss.tablespec, checked by pandera)."""
    try:
        check(frame, spec, spec.required)
    except ContractError as error:
        raise AnalysisInputError(f"{where}: {error}") from error


def _numeric(frame: pd.DataFrame, where: str, columns: Sequence[str]) -> None:
    """Parse ``columns`` as numbers in place; text, infinity or a value out of range is refused.

    The range is :data:`DECISION_RANGES`' (a time within a trial, whole
    counts), so a decision time of 1e300 s is named with its row instead of
    becoming a 300-digit mean. The CSV row number is counted as a spreadsheet
    shows it (header = row 1).
    """
    for name in columns:
        raw = frame[name]
        values = pd.to_numeric(raw, errors="coerce").astype(float)
        lowest, highest, whole = DECISION_RANGES[name]
        with np.errstate(invalid="ignore"):
            bad = (raw.notna() & values.isna()) | ~np.isfinite(values) & values.notna()
            bad |= (values < lowest) | (values > highest)
            if whole:
                bad |= values.notna() & (values != np.floor(values))
        if bad.any():
            position = int(np.flatnonzero(bad.to_numpy())[0])
            kind = "a whole number" if whole else "a number"
            raise AnalysisInputError(
                f"{where}: column {name!r} holds {str(raw.iloc[position])!r} in row "
                f"{position + 2}, expected {kind} from {lowest:g} to {highest:g}"
                + (
                    " (seconds; no decision outlasts its trial)"
                    if name == "decision_time_s"
                    else ""
                )
            )
        frame[name] = values


def _decisions(frame: pd.DataFrame, where: str) -> pd.DataFrame:
    decisions = _checked(frame, where, "decisions", DECISION_COLUMNS)
    _numeric(decisions, where, NUMERIC_DECISION_COLUMNS)
    sources = set(decisions["source"].dropna())
    unknown = sources - {SIMULATION, STUDY, SYNTHETIC}
    if unknown or decisions["source"].isna().any():
        raise AnalysisInputError(
            f"{where}: source must be 'simulation', 'study' or 'synthetic', "
            f"found {sorted(unknown) or 'empty'}"
        )
    difficulties = set(decisions["difficulty"].dropna()) - {"easy", "difficult"}
    if difficulties:
        raise AnalysisInputError(
            f"{where}: difficulty must be 'easy' or 'difficult', found {sorted(difficulties)}"
        )
    _keeps_contract(decisions, where, DECISIONS)
    decisions["participant"] = decisions["participant"].fillna("")
    decisions["group"] = pd.Series(
        [
            group_label(source, model)
            for source, model in zip(decisions["source"], decisions["model"], strict=True)
        ],
        index=decisions.index,
        dtype="object",
    )
    unknown_groups = set(decisions["group"]) - set(GROUP_ORDER)
    if unknown_groups:
        raise AnalysisInputError(f"{where}: unknown model(s) {sorted(unknown_groups)}")
    return decisions


def _empty(table: str) -> pd.DataFrame:
    columns = DECISION_COLUMNS + ("group",) if table == "decisions" else STUDY_TABLES[table]
    return pd.DataFrame({name: pd.Series(dtype="object") for name in (*columns, "input")})


def _read_input(path: Path) -> dict[str, pd.DataFrame]:
    """One INPUT's tables, checked and tagged with the INPUT they came from."""
    try:
        raw = read_tables(path, ("decisions", *STUDY_TABLES), TEXT_COLUMNS)
    except SourceError as error:
        raise AnalysisInputError(str(error)) from error
    if not raw:
        raise AnalysisInputError(
            f"{path}: no export tables here (decisions.csv, participants.csv, ...)"
        )
    tables = {}
    for table, (where, frame) in raw.items():
        if table == "decisions":
            frame = _decisions(frame, where)
        else:
            frame = _checked(frame, where, table, STUDY_TABLES[table])
            _keeps_contract(frame, where, EXPORT_TABLES[table])
        tables[table] = frame.assign(input=str(path))
    return tables


def _excluded_participants(participants: pd.DataFrame) -> set[str]:
    """Codes of bot, pilot and demo participants: never part of a real analysis."""
    flags = participants[["is_pilot", "is_bot", "is_demo"]].fillna(False).astype(bool)
    return set(participants.loc[flags.any(axis=1), "participant"].astype(str))


def _has_study_rows(combined: dict[str, pd.DataFrame]) -> bool:
    if (combined["decisions"]["source"] == STUDY).any():
        return True
    return any(len(combined[table]) for table in STUDY_TABLES if table != "participants")


def _exclude(combined: dict[str, pd.DataFrame]) -> None:
    """Drop bot, pilot and demo participants from every table, in place."""
    excluded = _excluded_participants(combined["participants"])
    for table, frame in combined.items():
        if "participant" in frame.columns and len(frame):
            combined[table] = frame[~frame["participant"].astype(str).isin(excluded)]


def _contributions(
    paths: list[Path], combined: dict[str, pd.DataFrame]
) -> tuple[InputSummary, ...]:
    summaries = []
    for path in paths:
        rows = {
            table: int((frame["input"] == str(path)).sum())
            for table, frame in combined.items()
            if "input" in frame.columns
        }
        summaries.append(InputSummary(str(path), tuple(sorted(rows.items()))))
    return tuple(summaries)


def _drop_participants(combined: dict[str, pd.DataFrame], codes: set[str]) -> None:
    """Leave these participants' rows out of every table (simulation decisions stay), in place."""
    for table, frame in combined.items():
        if "participant" in frame.columns and len(frame):
            combined[table] = frame[~frame["participant"].astype(str).isin(codes)]


def _keep_study(combined: dict[str, pd.DataFrame], study: str) -> None:
    """Keep one study's participants in every table (simulation decisions stay), in place."""
    kept = in_study(combined["participants"], study)
    if not kept:
        present = sorted({file.name for file in study_files(combined["participants"])} - {""})
        raise AnalysisInputError(
            f"no participant of study {study!r} in the inputs; studies there: "
            + (", ".join(present) or "none named")
        )
    for table, frame in combined.items():
        if "participant" in frame.columns and len(frame):
            keep = frame["participant"].astype(str).isin(kept)
            if table == "decisions":
                keep |= frame["source"] != STUDY
            combined[table] = frame[keep]


def _synthetic(decisions: pd.DataFrame, pool_synthetic: bool) -> tuple[str, ...]:
    """Read synthetic participants' decisions as a study's (in place); refuse them beside real
    participants' unless pooled. The warning that says so, or nothing."""
    synthetic = decisions["source"] == SYNTHETIC
    if not synthetic.any():
        return ()
    if (decisions["source"] == STUDY).any() and not pool_synthetic:
        raise AnalysisInputError(
            "the inputs hold synthetic participants (source = synthetic, from `hcss plan`) "
            "beside real ones; they are never analysed together unless asked "
            "(--pool-synthetic)"
        )
    decisions.loc[synthetic, "source"] = STUDY
    people = decisions.loc[synthetic, "participant"].nunique()
    return (
        f"{people} synthetic participant(s) (source = synthetic): simulated operators, "
        "not people; analysed as a study's teams",
    )


def load_inputs(
    paths: Iterable[str | Path],
    include_pilot: bool = False,
    study: str | None = None,
    pool_studies: bool = False,
    pool_synthetic: bool = False,
    completers_only: bool = False,
) -> StudyTables:
    """Read and combine every INPUT, tag groups and drop flagged participants.

    Study data without a participants table are refused unless
    ``include_pilot`` is set: without it there is no way to tell bots and
    pilots from real participants, and silently analysing them would be worse
    than stopping. An INPUT left with no rows after the exclusions is named
    in ``warnings`` (it does not vanish silently); when no INPUT is left with
    any row the analysis stops with that explanation.

    ``study`` keeps one study's participants; participants of different
    study files (name or digest) are refused unless ``pool_studies``
    (`hcss.analysis.studies`).

    Synthetic participants' decisions (``source = synthetic``) are analysed as a
    study's teams, with a warning saying so; beside real participants' they are
    refused unless ``pool_synthetic``.

    ``completers_only`` keeps only participants who completed; otherwise
    ``partial`` counts those who did not (their partial trials are analysed).
    """
    inputs = [Path(path) for path in paths]
    if not inputs:
        raise AnalysisInputError("no INPUT given")
    collected: dict[str, list[pd.DataFrame]] = {}
    for path in inputs:
        for table, frame in _read_input(path).items():
            collected.setdefault(table, []).append(frame)
    combined = {
        table: pd.concat(collected[table], ignore_index=True)
        if collected.get(table)
        else _empty(table)
        for table in ("decisions", *STUDY_TABLES)
    }
    synthetic_note = _synthetic(combined["decisions"], pool_synthetic)
    combined["participants"], never_opened = set_aside_never_opened(combined["participants"])
    if study is not None:
        _keep_study(combined, study)
    all_participants = combined["participants"].reset_index(drop=True)
    before = {summary.path: summary.rows for summary in _contributions(inputs, combined)}
    if _has_study_rows(combined) and not include_pilot:
        if not collected.get("participants"):
            raise AnalysisInputError(
                "study data were given without participants.csv, so bot, pilot and demo "
                "participants cannot be excluded; add the export's participants.csv or pass "
                "--include-pilot"
            )
        _exclude(combined)
    partial = not_completed(combined["participants"])
    if completers_only and partial:
        _drop_participants(combined, partial)
    studies = study_files(combined["participants"])
    if not pool_studies:
        try:
            refuse_pooling(studies)
        except StudyPoolingError as error:
            raise AnalysisInputError(str(error)) from error
    summaries = _contributions(inputs, combined)
    warnings = tuple(
        f"{summary.path} contributes nothing: "
        + (
            "every row belongs to a bot, pilot or demo participant (pass --include-pilot "
            "to analyse them)"
            if before[summary.path]
            else "its tables have no rows"
        )
        for summary in summaries
        if summary.rows == 0
    )
    if len(warnings) == len(inputs):
        raise AnalysisInputError("no data to analyse: " + "; ".join(warnings))
    warnings += synthetic_note
    for table in STUDY_TABLES:
        frame = combined[table]
        if "model" in frame.columns:
            frame = frame.assign(model=frame["model"].astype("string"))
        combined[table] = frame.reset_index(drop=True)
    combined["decisions"] = combined["decisions"].reset_index(drop=True)
    return StudyTables(
        **combined,
        all_participants=all_participants,
        inputs=summaries,
        warnings=warnings,
        studies=studies,
        never_opened=never_opened,
        partial=0 if completers_only else len(partial),
        completers_only=completers_only,
        left_out_partial=len(partial) if completers_only else 0,
    )
