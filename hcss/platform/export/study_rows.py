"""Per-participant rows: the wide participants table and the study-flow tables.

The study flow's enrolment, answers, scores and stage events live in the
study engine's models (`hcss.platform.models.study`). Answers and scores are
append-only there and a correction is a newer row, so the export carries the
newest row of each item or scale. A participant's status is the study
engine's own answer (`participant_statuses`), so the console, the
counterbalancing and the export never disagree about who completed.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.export.rows import iso
from hcss.platform.export.tables import DEMOGRAPHICS, MODELS, columns
from hcss.platform.models import (
    Participant,
    QuestionnaireItem,
    Score,
    StageEvent,
    StudyEnrolment,
    Trial,
)
from hcss.platform.models.pilots import pilot_flags
from hcss.platform.study.flow import DONE_KINDS, participant_statuses
from hcss.platform.study.studyfile import StudyFileError, load_study

Row = dict[str, Any]


def _newest(rows: list[Any], key) -> list[Any]:
    """The newest row (highest id) of each key, in the order the keys first appeared."""
    newest: dict[Any, Any] = {}
    for row in sorted(rows, key=lambda r: r.id):
        newest[key(row)] = row
    return sorted(newest.values(), key=lambda r: r.id)


def model_orders(session: Session, participants: list[Participant]) -> dict[int, str]:
    """Models in the order each participant met them in trials (``M2,M1,M3``), in one query."""
    wanted = {participant.id for participant in participants}
    met: dict[int, list[str]] = defaultdict(list)
    for participant_id, model in session.execute(
        select(Trial.participant_id, Trial.model).where(Trial.kind == "trial").order_by(Trial.id)
    ):
        if participant_id in wanted and model not in met[participant_id]:
            met[participant_id].append(model)
    return {participant_id: ",".join(models) for participant_id, models in met.items()}


def _by_participant(session: Session, model: Any) -> dict[int, list[Any]]:
    grouped: dict[int, list[Any]] = defaultdict(list)
    for row in session.scalars(select(model).order_by(model.id)):
        grouped[row.participant_id].append(row)
    return grouped


def participant_rows(session: Session, participants: list[Participant]) -> list[Row]:
    """One row per participant, read in a fixed number of queries (not a few per participant:
    an export of 5,000 took minutes)."""
    study = _study_records(session)
    orders = model_orders(session, participants)
    pilots = pilot_flags(session, participants)
    statuses = participant_statuses(session, participants)
    rows = []
    for participant in participants:
        row: Row = dict.fromkeys(columns("participants"))
        row.update(
            participant=participant.code,
            model_order=orders.get(participant.id) or None,
            is_pilot=pilots[participant.id],
            is_bot=participant.is_bot,
            is_demo=participant.is_demo,
            study=participant.study,  # the chosen study, until an enrolment says otherwise
        )
        records = {name: table.get(participant.id, []) for name, table in study.items()}
        row["status"] = statuses[participant.id]
        _fill_study_columns(row, records)
        row["mrt_part_items"] = mrt_part_items(row["study"])
        rows.append(row)
    return rows


def mrt_part_items(study: str | None) -> str | None:
    """The study file's items per timed MRT part (``12,12``): the report's MRT range is
    read from them, so a demo's one part of 4 is never labelled 0–24 (`load_study`
    caches the file). None without a readable study file (one since removed: its data
    still export)."""
    if not study:
        return None
    try:
        return ",".join(str(count) for count in load_study(study).mrt.part_items)
    except StudyFileError:
        return None


def _study_records(session: Session) -> dict[str, dict[int, list[Any]]]:
    return {
        "enrolment": _by_participant(session, StudyEnrolment),
        "stages": _by_participant(session, StageEvent),
        "items": _by_participant(session, QuestionnaireItem),
        "scores": _by_participant(session, Score),
    }


def _fill_study_columns(row: Row, records: dict[str, list[Any]]) -> None:
    if records["enrolment"]:
        enrolment = records["enrolment"][-1]
        row.update(
            study=enrolment.study,
            study_digest=enrolment.study_digest,
            cell=enrolment.cell,
            model_order=enrolment.model_order,
        )
    answers = {
        item.item: item.value
        for item in _newest(records["items"], lambda i: (i.instrument, i.model, i.item))
        if item.instrument == "demographics"
    }
    row.update({key: answers.get(key) for key in DEMOGRAPHICS})
    scores = {
        (s.instrument, s.model, s.scale): s.score
        for s in _newest(records["scores"], lambda s: (s.instrument, s.model, s.scale))
    }
    total = scores.get(("mrt", "", "total"))
    row["mrt_score"] = None if total is None else int(total)
    for model in MODELS:
        row[f"tlx_overall_{model}"] = scores.get(("nasa_tlx", model, "overall"))
        row[f"sart_{model}"] = scores.get(("sart", model, "overall"))


def study_flow_rows(session: Session, participants: list[Participant]) -> dict[str, list[Row]]:
    """questionnaire_items, scores, stage_timings and late_answers rows."""
    tables: dict[str, list[Row]] = {
        "questionnaire_items": [],
        "scores": [],
        "stage_timings": [],
        "late_answers": [],
    }
    study = _study_records(session)
    for participant in participants:
        code = participant.code
        for item in _newest(
            study["items"].get(participant.id, []), lambda i: (i.instrument, i.model, i.item)
        ):
            tables["questionnaire_items"].append(
                {
                    "participant": code,
                    "wall_time": iso(item.created_at),
                    "instrument": item.instrument,
                    "model": item.model or None,
                    "item": item.item,
                    "value": item.value,
                }
            )
        for score in _newest(
            study["scores"].get(participant.id, []), lambda s: (s.instrument, s.model, s.scale)
        ):
            tables["scores"].append(
                {
                    "participant": code,
                    "instrument": score.instrument,
                    "model": score.model or None,
                    "scale": score.scale,
                    "score": score.score,
                }
            )
        tables["stage_timings"].extend(
            stage_timing_rows(code, study["stages"].get(participant.id, []))
        )
        tables["late_answers"].extend(
            late_answer_rows(code, study["stages"].get(participant.id, []))
        )
    return tables


def late_answer_rows(code: str, events: list[Any]) -> list[Row]:
    """One row per value of each ``late_answer`` event (answers sent after a skip)."""
    rows = []
    for event in sorted(events, key=lambda e: e.id):
        if event.kind != "late_answer":
            continue
        answers = (event.detail or {}).get("answers", {})
        for item, values in answers.items():
            for value in values if isinstance(values, list) else [values]:
                rows.append(
                    {
                        "participant": code,
                        "stage_index": event.stage_index,
                        "stage": event.stage,
                        "step": event.step,
                        "model": event.model or None,
                        "answered_at": iso(event.at),
                        "item": str(item),
                        "value": None if value is None else str(value),
                    }
                )
    return rows


def stage_timing_rows(code: str, events: list[Any]) -> list[Row]:
    """One row per stage: first entry, and the last submission once a later stage began.

    A stage has several steps (MRT parts, introduction pages); it counts as
    submitted when the participant has moved on to a later stage, or, for the
    last stage reached, when its newest event is a submission.
    """
    stages: dict[int, list[Any]] = defaultdict(list)
    for event in sorted(events, key=lambda e: e.id):
        stages[event.stage_index].append(event)
    last_index = max(stages, default=-1)
    rows = []
    for index in sorted(stages):
        stage_events = stages[index]
        entered = [e.at for e in stage_events if e.kind == "entered"]
        ends = [e for e in stage_events if e.kind in DONE_KINDS]
        finished = bool(ends) and (index < last_index or stage_events[-1].kind != "entered")
        rows.append(
            {
                "participant": code,
                "stage_index": index,
                "stage": stage_events[0].stage,
                "model": stage_events[0].model or None,
                "entered_at": iso(min(entered)) if entered else None,
                "submitted_at": iso(max(e.at for e in ends)) if finished else None,
                "timed_out": any(e.kind == "timed_out" for e in stage_events),
                "skipped": any(e.kind == "skipped" for e in stage_events),
            }
        )
    return rows
