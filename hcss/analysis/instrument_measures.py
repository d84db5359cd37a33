"""Measures from SA probes and questionnaires, one value per participant.

Probes are scored per trial:

- ``sa_overall`` (SA0) = 100 * correct probes / scored probes, over all
  levels; ``sa_level1`` … ``sa_level3`` the same within a level.
- A probe that timed out counts as incorrect: the operator could not answer
  in time, which is a failure of awareness, not a missing value.
- A probe not yet scored (``correct`` empty and not timed out, e.g. a
  level-3 projection whose outcome never happened before the trial ended) is
  left out, since it has no truth to compare with.

Questionnaires come from the export's ``scores`` table (the instruments'
own scoring: TLX weighting, SART's SU − (DAR − SAR), MRT's item rule), so the
analysis never re-implements scoring. The MRT is one measure per participant,
its total over both parts (:func:`mrt_scores`); the export's per-part rows are
halves of the test, not scores. An instrument with no scores falls
back to its raw numeric ``questionnaire_items`` (e.g. the 1–7 post-trial
Likert answers, or ranks), one measure per item. The export never
overwrites, so a corrected answer is a later row: the last row wins.
"""

from __future__ import annotations

import pandas as pd

from hcss.analysis.decision_measures import MEASURE_COLUMNS
from hcss.analysis.load import STUDY
from hcss.questionnaires.tlx import SUBSCALE_KEYS

#: Per-model instruments, in report order.
MODEL_INSTRUMENTS = ("nasa_tlx", "sart", "post_trial", "ranking")

#: Group label for per-participant measures (not tied to a model).
ALL_PARTICIPANTS = "All"


def probe_measures(probes: pd.DataFrame) -> pd.DataFrame:
    """SA probe percent correct per trial: overall (SA0) and per level."""
    if probes.empty:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    correct = probes["correct"].astype("boolean")
    timed_out = probes["timed_out"].astype("boolean").fillna(False).astype(bool)
    scored = probes.assign(
        hit=correct.fillna(False).astype(bool), scored=correct.notna().to_numpy() | timed_out
    )
    scored = scored[scored["scored"]]
    rows = []
    for (participant, _trial, model), trial_probes in scored.groupby(
        ["participant", "trial_id", "model"], sort=True
    ):
        subsets = [("sa_overall", trial_probes)] + [
            (f"sa_level{int(level)}", level_probes)
            for level, level_probes in trial_probes.groupby("level")
        ]
        for measure, subset in subsets:
            value = 100.0 * subset["hit"].mean()
            rows.append((measure, "overall", str(model), STUDY, participant, participant, value))
    frame = pd.DataFrame(rows, columns=MEASURE_COLUMNS)
    return frame.groupby(MEASURE_COLUMNS[:-1], as_index=False)["value"].mean()[MEASURE_COLUMNS]


def _latest(frame: pd.DataFrame, key: list[str]) -> pd.DataFrame:
    return frame.drop_duplicates(subset=key, keep="last")


def _item_rows(
    items: pd.DataFrame, instrument: str, name_column: str, value_column: str
) -> pd.DataFrame:
    """Rows of one instrument as measures named ``instrument.scale``."""
    chosen = items[items["instrument"] == instrument].copy()
    chosen["value"] = pd.to_numeric(chosen[value_column], errors="coerce")
    chosen = chosen.dropna(subset=["value"])
    model = chosen["model"].astype("string").fillna("")
    chosen["group"] = model.where(model != "", ALL_PARTICIPANTS)
    chosen["measure"] = instrument + "." + chosen[name_column].astype(str)
    chosen["split"] = "overall"
    chosen["source"] = STUDY
    chosen["unit"] = chosen["participant"].astype(str)
    chosen["participant"] = chosen["unit"]
    return chosen[MEASURE_COLUMNS]


def _tlx_ratings(items: pd.DataFrame) -> pd.DataFrame:
    """The six raw NASA-TLX ratings (0–100) as ``nasa_tlx.<subscale>_rating``.

    The scores table holds the weighted components and both totals; the raw
    ratings are answers, so they come from the items, beside the weighted
    ones in the paper's TLX table.
    """
    ratings = items[(items["instrument"] == "nasa_tlx") & items["item"].isin(SUBSCALE_KEYS)]
    ratings = ratings.assign(item=ratings["item"].astype(str) + "_rating")
    return _item_rows(ratings, "nasa_tlx", "item", "value")


def questionnaire_measures(scores: pd.DataFrame, items: pd.DataFrame) -> pd.DataFrame:
    """NASA-TLX, SART, post-trial and ranking, from scores or raw items (the MRT: :func:`mrt_scores`)."""
    scores = _latest(scores, ["participant", "instrument", "model", "scale"])
    items = _latest(items, ["participant", "instrument", "model", "item"])
    frames = []
    for instrument in MODEL_INSTRUMENTS:
        if (scores["instrument"] == instrument).any():
            frames.append(_item_rows(scores, instrument, "scale", "score"))
            if instrument == "nasa_tlx":
                frames.append(_tlx_ratings(items))
        elif (items["instrument"] == instrument).any():
            frames.append(_item_rows(items, instrument, "item", "value"))
    frames = [frame for frame in frames if not frame.empty]
    if not frames:
        return pd.DataFrame(columns=MEASURE_COLUMNS)
    return pd.concat(frames, ignore_index=True)


#: The MRT's parts: a total is the sum of both, never of one.
MRT_PARTS = ("part_1", "part_2")


def _mrt_rows(scores: pd.DataFrame) -> dict[str, dict[str, float]]:
    """participant -> scale -> score, the latest row of each (a corrected score comes later)."""
    mrt = _latest(scores[scores["instrument"] == "mrt"], ["participant", "scale"]).assign(
        score=lambda frame: pd.to_numeric(frame["score"], errors="coerce")
    )
    mrt = mrt.dropna(subset=["score"])
    mrt = mrt.assign(participant=mrt["participant"].astype(str))
    return {
        str(participant): dict(zip(rows["scale"].astype(str), rows["score"], strict=True))
        for participant, rows in mrt.groupby("participant", sort=True)
    }


def _whole(by_scale: dict[str, float]) -> float | None:
    """The total of one participant's rows: `total` (`overall` in older exports), else the
    sum of both parts; None with one part only (half the test is not its score)."""
    for whole in ("total", "overall"):
        if whole in by_scale:
            return float(by_scale[whole])
    if all(part in by_scale for part in MRT_PARTS):
        return float(sum(by_scale[part] for part in MRT_PARTS))
    return None


def _stored(participants: pd.DataFrame) -> pd.Series:
    if "mrt_score" not in participants.columns or not len(participants):
        return pd.Series(dtype=float)
    stored = participants.assign(participant=participants["participant"].astype(str))
    return pd.to_numeric(stored.set_index("participant")["mrt_score"], errors="coerce").dropna()


def mrt_scores(scores: pd.DataFrame, participants: pd.DataFrame) -> pd.Series:
    """Each participant's MRT score: the total over both parts (0–24), by participant code.

    The export's ``scores`` rows are ``total``, ``part_1`` and ``part_2``; the
    score is ``total`` (``overall`` in older exports), else the sum of both
    parts, never one part alone. The participants table's ``mrt_score`` (the
    stored total) is used for a participant without either; one without any
    total is left out (:func:`incomplete_mrt_note` says who).
    """
    totals = {
        participant: whole
        for participant, by_scale in _mrt_rows(scores).items()
        if (whole := _whole(by_scale)) is not None
    }
    found = pd.Series(totals, dtype=float)
    stored = _stored(participants)
    found = pd.concat([found, stored[~stored.index.isin(found.index)]])
    return found.sort_index()


def incomplete_mrt_note(scores: pd.DataFrame, participants: pd.DataFrame) -> str:
    """Who has one MRT part only, and what their score became; "" when nobody."""
    one_part = sorted(
        participant
        for participant, by_scale in _mrt_rows(scores).items()
        if _whole(by_scale) is None
    )
    if not one_part:
        return ""
    stored = _stored(participants)
    used = [participant for participant in one_part if participant in stored.index]
    shown = ", ".join(one_part[:10]) + (
        f" and {len(one_part) - 10} more" if len(one_part) > 10 else ""
    )
    return (
        f"{len(one_part)} participant{'s have' if len(one_part) != 1 else ' has'} one MRT part "
        f"only ({shown}): half the test is not its score, so the stored total is used where "
        f"the participants table has one and the participant is left out otherwise (stored "
        f"total used for {len(used)}, left out: {len(one_part) - len(used)})."
    )


def mrt_range_note(participants: pd.DataFrame) -> str:
    """The MRT score's range in each analysed study, from the export's ``mrt_part_items``
    (the study file's items per timed part): ``0–4 in demo (one timed part of 4 items)``.
    A demo's one part of 4 is never read as the original's 0–24. "" for an export without
    the column."""
    if "mrt_part_items" not in participants.columns or "study" not in participants.columns:
        return ""
    known = participants.dropna(subset=["mrt_part_items", "study"])
    ranges = []
    for (study, parts), _ in known.groupby(["study", "mrt_part_items"], sort=True):
        counts = [int(float(count)) for count in str(parts).split(",") if count.strip()]
        if not counts:
            continue
        if len(counts) == 1:
            shape = f"one timed part of {counts[0]} items"
        elif len(set(counts)) == 1:
            shape = f"{len(counts)} timed parts of {counts[0]} items"
        else:
            shape = f"timed parts of {', '.join(map(str, counts))} items"
        ranges.append(f"0–{sum(counts)} in {study} ({shape})")
    return f"MRT score range: {'; '.join(ranges)}." if ranges else ""
