"""The export tests' helpers: its CSV files, the data dictionary's columns, a study's rows."""

from __future__ import annotations

import csv
import re
from datetime import UTC, datetime, timedelta
from pathlib import Path

from hcss.platform.export.writer import DICTIONARY
from hcss.platform.models import Participant, study


def dictionary_columns() -> dict[str, list[str]]:
    """Each table's columns as docs/data-dictionary.md lists them, read from its Markdown."""
    tables: dict[str, list[str]] = {}
    current = None
    for line in DICTIONARY.read_text(encoding="utf-8").splitlines():
        heading = re.match(r"#{2,3} (\w+)", line)
        if heading:
            current = heading.group(1) if heading.group(1).islower() else None
            continue
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if current and line.startswith("|") and cells[0] not in ("column", "---"):
            tables.setdefault(current, []).extend(n.strip(" `") for n in cells[0].split(","))
    return tables


def read_csv(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open(encoding="utf-8", newline="") as handle:
        reader = csv.DictReader(handle)
        return list(reader.fieldnames or []), list(reader)


T0 = datetime(2026, 11, 22, 9, 0, tzinfo=UTC)


def at_second(seconds: float) -> datetime:
    return T0 + timedelta(seconds=seconds)


def record_study(session, participant: Participant) -> None:
    """What the study flow writes for a participant who reached the first post-trial form."""
    pid = participant.id
    session.add(
        study.StudyEnrolment(
            participant_id=pid,
            study="original",
            study_digest="0" * 64,
            cell=3,
            model_order="M2,M1,M3",
            first_sections={"M1": "easy", "M2": "difficult", "M3": "easy"},
            pool="real",
        )
    )
    session.add(
        study.ConsentRecord(participant_id=pid, version="v1", decision="agree", at=at_second(5))
    )
    events = [
        (0, "consent", "", "form", "entered", 0),
        (0, "consent", "", "form", "submitted", 5),
        (1, "demographics", "", "form", "entered", 5),
        (1, "demographics", "", "form", "submitted", 65),
        (2, "mental_rotation", "", "part_1", "entered", 65),
        (2, "mental_rotation", "", "part_1", "timed_out", 245),
        (2, "mental_rotation", "", "part_2", "entered", 250),
        (2, "mental_rotation", "", "part_2", "submitted", 400),
        (3, "post_trial", "M2", "form", "entered", 500),
    ]
    for index, stage, model, step, kind, at in events:
        session.add(
            study.StageEvent(
                participant_id=pid,
                stage_index=index,
                stage=stage,
                step=step,
                model=model,
                kind=kind,
                at=at_second(at),
            )
        )
    answers = [
        ("demographics", "", "age_band", "18-30"),
        ("demographics", "", "gender", "female"),
        ("demographics", "", "video_games", "2"),
        ("demographics", "", "video_games", "3"),  # a correction: the newer row wins
        ("nasa_tlx", "M2", "mental_demand", "55"),
    ]
    for instrument, model, item, value in answers:
        session.add(
            study.QuestionnaireItem(
                participant_id=pid,
                stage_index=1,
                instrument=instrument,
                model=model,
                item=item,
                value=value,
                at=at_second(60),
            )
        )
    for instrument, model, scale, score in [
        ("mrt", "", "total", 17.0),
        ("mrt", "", "part_1", 9.0),
        ("nasa_tlx", "M2", "overall", 48.5),
        ("sart", "M2", "overall", 6.0),
    ]:
        session.add(
            study.Score(
                participant_id=pid, instrument=instrument, model=model, scale=scale, score=score
            )
        )
    session.flush()
