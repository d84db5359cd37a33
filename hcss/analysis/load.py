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
#: The key of a decision across every INPUT: one row per key (the study's database has the
#: same unique index on a trial's decisions).
DECISION_KEY = ("source", "trial_id", "collective", "decision_index")
#: How far end_s − start_s may stray from decision_time_s: a hundredth of a second, above
#: the rounding of any CSV writer and below the whole seconds the study's clock counts.
TIME_TOLERANCE_S = 0.01
#: Offending values named in a refusal; the rest are counted.
SHOWN_VALUES = 3
TEXT_COLUMNS = frozenset(
    column.name for column in DECISIONS.columns if column.required and column.dtype == "str"
)


class AnalysisInputError(ValueError):
    """An input the analysis cannot use, explained for the command line."""


def _first_values(values: pd.Series, rows: pd.Series) -> str:
    """The first few offending values with their rows, the rest counted: a refusal stays a
    line or two however many rows break the rule."""
    shown = ", ".join(
        f"{str(value)[:60]!r} (row {row})"
        for value, row in zip(values.iloc[:SHOWN_VALUES], rows.iloc[:SHOWN_VALUES], strict=True)
    )
    more = len(values) - SHOWN_VALUES
    return shown + (f" and {more} more" if more > 0 else "")


def _spreadsheet_rows(mask: pd.Series) -> pd.Series:
    """Rows as a spreadsheet counts them (header = row 1) where ``mask`` holds."""
    return pd.Series(np.flatnonzero(mask.to_numpy()) + 2)


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


def _one_of(frame: pd.DataFrame, where: str, column: str, allowed: tuple[str, ...]) -> None:
    """Refuse a text column holding anything but ``allowed``, naming the first values."""
    bad = ~frame[column].isin(allowed)
    if bad.any():
        raise AnalysisInputError(
            f"{where}: {column} must be "
            + " or ".join(repr(value) for value in allowed)
            + f", found {_first_values(frame.loc[bad, column].fillna('(empty)'), _spreadsheet_rows(bad))}"
        )


def _refuse_foreign_delimiter(frame: pd.DataFrame, where: str) -> None:
    """A comma header over rows written with another delimiter: each row is one field.

    pandas reads such a row into the first column and leaves the others empty; without
    this the first rule to notice (the source's values) listed every row in one line.
    """
    first = frame[frame.columns[0]].astype("string")
    others = frame[[name for name in DECISION_COLUMNS if name != frame.columns[0]]]
    for delimiter, name in ((";", "semicolons"), ("\t", "tabs"), ("|", "bars")):
        one_field = first.str.contains(delimiter, regex=False).fillna(False) & others.isna().all(
            axis=1
        )
        if one_field.any():
            position = int(np.flatnonzero(one_field.to_numpy())[0])
            raise AnalysisInputError(
                f"{where}: row {position + 2} is one field separated by {name} "
                f"({str(first.iloc[position])[:60]!r}) under a comma-separated header; the "
                "export's tables are comma-separated CSV (save as CSV with commas)"
            )


def _times_agree(decisions: pd.DataFrame, where: str) -> None:
    """Refuse a decision whose end_s − start_s is not its decision_time_s.

    end_s orders the decisions into the study's slots and decision_time_s is what the
    tables average; if they disagree, one of them is wrong and the tables would mix both.
    """
    if not {"start_s", "end_s"} <= set(decisions.columns):
        return
    start = pd.to_numeric(decisions["start_s"], errors="coerce").astype(float)
    end = pd.to_numeric(decisions["end_s"], errors="coerce").astype(float)
    duration = decisions["decision_time_s"].astype(float)
    with np.errstate(invalid="ignore"):
        apart = (end - start - duration).abs() > TIME_TOLERANCE_S
    apart &= start.notna() & end.notna() & duration.notna()
    if apart.any():
        rows = np.flatnonzero(apart.to_numpy())
        first = rows[0]
        raise AnalysisInputError(
            f"{where}: {len(rows)} decision(s) whose end_s − start_s is not decision_time_s "
            f"(tolerance {TIME_TOLERANCE_S:g} s); first, row {first + 2}: end_s "
            f"{end.iloc[first]:g} − start_s {start.iloc[first]:g} = "
            f"{end.iloc[first] - start.iloc[first]:g} s, but decision_time_s is "
            f"{duration.iloc[first]:g}"
        )


def _decisions(frame: pd.DataFrame, where: str) -> pd.DataFrame:
    decisions = _checked(frame, where, "decisions", DECISION_COLUMNS)
    _refuse_foreign_delimiter(decisions, where)
    _numeric(decisions, where, NUMERIC_DECISION_COLUMNS)
    _one_of(decisions, where, "source", (SIMULATION, STUDY, SYNTHETIC))
    _one_of(decisions, where, "difficulty", ("easy", "difficult"))
    _keeps_contract(decisions, where, DECISIONS)
    _times_agree(decisions, where)  # once every cell has its type
    decisions["participant"] = decisions["participant"].fillna("")
    decisions["group"] = pd.Series(
        [
            group_label(source, model)
            for source, model in zip(decisions["source"], decisions["model"], strict=True)
        ],
        index=decisions.index,
        dtype="object",
    )
    unknown_groups = ~decisions["group"].isin(GROUP_ORDER)
    if unknown_groups.any():
        raise AnalysisInputError(
            f"{where}: unknown model(s) "
            + _first_values(
                decisions.loc[unknown_groups, "model"], _spreadsheet_rows(unknown_groups)
            )
        )
    return decisions.assign(_where=where, _row=np.arange(len(decisions)) + 2)


#: Columns that say where a decision row was read, not what it holds.
_PLACE = ("input", "_where", "_row")


def _same(left: object, right: object) -> bool:
    return bool(pd.isna(left) and pd.isna(right)) or bool(left == right)


def _one_row_per_decision(decisions: pd.DataFrame, drop_exact: bool) -> tuple[pd.DataFrame, int]:
    """The decisions with each key once, and how many exact copies were dropped.

    A key given twice is refused naming both places: the same INPUT given twice, or a
    row copied inside one, would otherwise double every count and N. With ``drop_exact``
    rows identical in every read column are dropped (first kept) and counted; copies that
    differ in any column are refused still, since which one is right cannot be known.
    """
    if decisions.empty:
        return decisions, 0
    content = [name for name in decisions.columns if name not in _PLACE]
    dropped = 0
    if drop_exact:
        exact = decisions.duplicated(subset=content, keep="first")
        dropped = int(exact.sum())
        decisions = decisions[~exact]
    key = list(DECISION_KEY)
    repeated = decisions.duplicated(subset=key, keep=False)
    if not repeated.any():
        return decisions, dropped
    clash = decisions[repeated]
    keys = clash[key].drop_duplicates()
    first = clash[(clash[key] == keys.iloc[0]).all(axis=1)]
    one, other = first.iloc[0], first.iloc[1]
    differing = [name for name in content if not _same(one[name], other[name])]
    source, trial, collective, index = (one[name] for name in key)
    why = (
        f"they differ in {', '.join(differing[:SHOWN_VALUES])}"
        if differing
        else "the rows are identical (an INPUT given twice?); --drop-exact-duplicates drops "
        "rows identical in every column and counts them"
    )
    raise AnalysisInputError(
        f"{len(keys)} decisions appear more than once across the inputs (one row per source, "
        f"trial, collective and decision index); first: {source} trial {trial}, collective "
        f"{collective}, decision {int(float(index))} in {one['_where']} row {one['_row']} and "
        f"{other['_where']} row {other['_row']};\n{why}"
    )


def _one_row_per_participant(combined: dict[str, pd.DataFrame], drop_exact: bool) -> int:
    """Refuse a participant listed twice (the same export given twice doubles every
    questionnaire and probe too); with ``drop_exact``, drop rows identical in every column
    of every export table instead, in place, and return how many."""
    dropped = 0
    if drop_exact:
        for table in STUDY_TABLES:
            frame = combined[table]
            content = [name for name in frame.columns if name != "input"]
            exact = frame.duplicated(subset=content, keep="first") if len(frame) else frame.index
            if len(frame) and exact.any():
                dropped += int(exact.sum())
                combined[table] = frame[~exact]
    people = combined["participants"]
    if not len(people):
        return dropped
    coded = people[people["participant"].notna() & (people["participant"].astype(str) != "")]
    repeated = coded[coded["participant"].astype(str).duplicated(keep=False)]
    if len(repeated):
        code = str(repeated["participant"].iloc[0])
        places = sorted(
            {
                str(place)
                for place in repeated.loc[repeated["participant"].astype(str) == code, "input"]
            }
        )
        raise AnalysisInputError(
            f"{repeated['participant'].astype(str).nunique()} participants appear more than "
            f"once in the participants tables; first: {code} in {' and '.join(places)} "
            "(the same export given twice, or two exports that overlap?)"
        )
    return dropped


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
    drop_exact_duplicates: bool = False,
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
    (`hcss.analysis.studies`). Each decision key (:data:`DECISION_KEY`) appears once over
    all INPUTs; ``drop_exact_duplicates`` drops rows identical in every column (counted in
    ``warnings``) instead of refusing them.

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
    combined["decisions"], dropped = _one_row_per_decision(
        combined["decisions"], drop_exact_duplicates
    )
    combined["decisions"] = combined["decisions"].drop(columns=["_where", "_row"], errors="ignore")
    dropped += _one_row_per_participant(combined, drop_exact_duplicates)
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
    if dropped:
        warnings += (
            f"dropped {dropped} exact duplicate rows (--drop-exact-duplicates): rows "
            "identical in every column to one read before",
        )
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
