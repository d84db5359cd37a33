"""Who is in the analysis: sample, attrition by stage, demographics.

Counted from the participants table *before* exclusions, because a reader
must see how many were enrolled, how many completed or withdrew, and how
many bot, pilot and demo participants were set aside, not only who is left.
"""

from __future__ import annotations

import pandas as pd

from hcss.analysis.tables import Table, format_number
from hcss.tablespec.analysis import ATTRITION, DEMOGRAPHICS

#: Demographic answers reported as counts per category.
CATEGORICAL = ("age_band", "gender", "education", "colour_vision")
#: Demographic answers on a numeric scale, reported as mean (SD).
NUMERIC = ("video_games", "robots", "mrt_score")

STATUS_LABELS = {
    "completed": "Completed",
    "in_progress": "In progress",
    "aborted": "Stopped before the end (aborted or withdrew)",
    "declined": "Declined consent",
}


def _flags(participants: pd.DataFrame) -> pd.DataFrame:
    columns = [name for name in ("is_bot", "is_pilot", "is_demo") if name in participants]
    return participants[columns].fillna(False).astype(bool)


def real_participants(participants: pd.DataFrame) -> pd.DataFrame:
    """Participants who are neither bots, pilots nor demos."""
    if participants.empty:
        return participants
    return participants[~_flags(participants).any(axis=1)]


def sample_table(participants: pd.DataFrame, include_pilot: bool) -> Table:
    """Enrolled, completed, withdrawn, declined, in progress; excluded by kind."""
    flags = _flags(participants) if len(participants) else pd.DataFrame()
    real = real_participants(participants)
    status = real["status"].astype(str) if "status" in real else pd.Series(dtype=str)
    rows = [("Enrolled (real participants)", len(real))]
    rows += [(label, int((status == key).sum())) for key, label in STATUS_LABELS.items()]
    kinds = {"is_bot": "bots", "is_pilot": "pilots", "is_demo": "demos"}
    verb = "Included" if include_pilot else "Excluded"
    for column, label in kinds.items():
        count = int(flags[column].sum()) if column in flags else 0
        rows.append((f"{verb}: {label}", count))
    return Table(
        "sample",
        "Sample: participants by status, and bots, pilots and demos",
        ("Participants", "n"),
        tuple((label, str(count)) for label, count in rows),
        pd.DataFrame(rows, columns=["row", "n"]),
    )


def attrition_table(stage_timings: pd.DataFrame) -> Table:
    """Per stage, in protocol order: analysed participants who entered, submitted, were
    moved past it by the experimenter (the export's ``skipped``), or left it unsubmitted.

    ``stage_timings`` is the analysed table (bots, pilots and demos already
    excluded unless --include-pilot). A skipped stage has a submission time (when it was
    skipped) and often no entry: it counts as skipped, not as submitted, so no column
    is ever negative.
    """
    timings = stage_timings
    rows, records = [], []
    if not timings.empty:
        if "stage_index" in timings:
            position = pd.to_numeric(timings["stage_index"], errors="coerce")
        else:  # older exports: the order rows were written in
            position = pd.Series(range(len(timings)), index=timings.index, dtype=float)
        skipped = _skipped(timings)
        order = (
            timings.assign(position=position)
            .groupby("stage", sort=False)["position"]
            .median()
            .sort_values(kind="stable")
        )
        for stage in order.index:
            here = timings["stage"] == stage
            chosen = timings[here]
            moved = skipped[here]
            entered = chosen[chosen["entered_at"].notna()]["participant"].nunique()
            passed = set(chosen[moved]["participant"])
            done = set(chosen[chosen["submitted_at"].notna()]["participant"]) - passed
            left = set(chosen[chosen["entered_at"].notna()]["participant"]) - done - passed
            counts = (entered, len(done), len(passed), len(left))
            rows.append((str(stage), *(str(count) for count in counts)))
            records.append(dict(zip(ATTRITION.names, (stage, *counts), strict=True)))
    return Table(
        "attrition",
        "Attrition by stage (analysed participants who entered each stage, submitted it, "
        "were moved past it by the experimenter, or left it unsubmitted)",
        ("Stage", "Entered", "Submitted", "Skipped by the experimenter", "Did not submit"),
        tuple(rows),
        pd.DataFrame(records, columns=list(ATTRITION.names)),
    )


def _skipped(timings: pd.DataFrame) -> pd.Series:
    """The export's ``skipped`` column as booleans (false when an older export lacks it)."""
    if "skipped" not in timings:
        return pd.Series(False, index=timings.index)
    text = timings["skipped"].astype("string").str.strip().str.lower()
    return text.isin(["true", "1"]).fillna(False).astype(bool)


def demographics_table(participants: pd.DataFrame) -> Table:
    """Counts per category and mean (SD) of numeric answers of the analysed participants.

    Only participants who answered at least one demographic item count: a
    visitor who never reached the questionnaire is no "not answered".
    """
    asked = [name for name in (*CATEGORICAL, *NUMERIC[:2]) if name in participants]
    real = participants[participants[asked].notna().any(axis=1)] if asked else participants
    rows, records = [], []
    for column in CATEGORICAL:
        if column not in real:
            continue
        counts = real[column].astype("string").fillna("not answered").value_counts(sort=False)
        for value, count in sorted(counts.items()):
            share = 100.0 * count / max(len(real), 1)
            rows.append((column.replace("_", " "), str(value), f"{count} ({share:.0f}%)"))
            records.append({"item": column, "value": value, "n": count, "mean": None, "sd": None})
    for column in NUMERIC:
        if column not in real:
            continue
        values = pd.to_numeric(real[column], errors="coerce").dropna()
        if values.empty:
            continue
        sd = values.std(ddof=1) if len(values) > 1 else float("nan")
        text = f"{format_number(values.mean())} ({format_number(sd)}), n = {len(values)}"
        rows.append((column.replace("_", " "), "mean (SD)", text))
        records.append(
            {"item": column, "value": "mean", "n": len(values), "mean": values.mean(), "sd": sd}
        )
    return Table(
        "demographics",
        "Demographics of the analysed participants",
        ("Item", "Answer", "n (%) or mean (SD)"),
        tuple(rows),
        pd.DataFrame(records, columns=list(DEMOGRAPHICS.names)),
    )


def counterbalancing_table(participants: pd.DataFrame) -> Table:
    """Analysed participants per counterbalancing cell and model order, by status."""
    if participants.empty or "cell" not in participants.columns:
        return Table("counterbalancing", "", ("Cell",), (), pd.DataFrame())
    people = participants.assign(
        cell=participants["cell"].astype("Int64").astype(str),
        model_order=participants.get("model_order", pd.Series(dtype=str)).fillna("–"),
        status=participants.get("status", pd.Series(dtype=str)).fillna("unknown"),
    )
    counts = people.groupby(["cell", "model_order", "status"]).size().unstack(fill_value=0)
    statuses = list(counts.columns)
    rows = [
        (cell, order, *(str(int(counts.loc[(cell, order), status])) for status in statuses))
        for cell, order in counts.index
    ]
    return Table(
        "counterbalancing",
        "Counterbalancing achieved: analysed participants per cell and model order, by status",
        ("Cell", "Model order", *(STATUS_LABELS.get(status, status) for status in statuses)),
        tuple(rows),
        counts.reset_index(),
    )
