"""One participant through the whole original protocol over HTTP, time accelerated.

A participant bot walks every page (asserting each is the page the study file
says comes next); then the database must hold every row the protocol
promises, and the export must carry them.
"""

from __future__ import annotations

from collections import Counter

import pytest
from click.testing import CliRunner
from sqlalchemy import select

from hcss.cli import main
from hcss.platform.bots.participant import ParticipantBot, expected_pages
from hcss.platform.live.trials import latest_status
from hcss.platform.models import (
    ConsentRecord,
    Participant,
    Probe,
    QuestionnaireItem,
    Score,
    StageEvent,
    StudyEnrolment,
    Trial,
)
from hcss.platform.study import load_study, participant_status
from hcss.questionnaires import demographics, post_trial, ranking, sart, tlx
from tests.support.study import new_participant

#: The bot looks every 6 trial seconds and decides every 18 (2 and 6 by default): the six
#: trials' 72 minutes are half the requests, and every row the walk must leave is still left.
LOOK_S, DECIDE_S = 6.0, 18.0


@pytest.mark.slow
def test_the_whole_original_protocol_leaves_every_row(study_app, database_url, tmp_path) -> None:
    study = load_study("original")
    token = new_participant(study_app, is_bot=True)
    report = ParticipantBot(study_app, token, seed=3, tick_s=LOOK_S, policy_every_s=DECIDE_S).run(
        study
    )
    assert report.pages == len(expected_pages(study))
    assert report.mrt_answers == 4 + 24 and report.probes_answered > 0 and report.accepted > 0

    database = study_app.extensions["hcss_db"]
    with database.session_scope() as session:
        participant = session.scalars(select(Participant).where(Participant.token == token)).one()
        pid = participant.id
        assert participant_status(session, participant) == "completed"
        (enrolment,) = session.scalars(
            select(StudyEnrolment).where(StudyEnrolment.participant_id == pid)
        )
        order = enrolment.models()
        assert order[2] == "M3" and sorted(order) == ["M1", "M2", "M3"]

        (consent,) = session.scalars(
            select(ConsentRecord).where(ConsentRecord.participant_id == pid)
        )
        assert (consent.version, consent.decision) == ("v1", "agree")

        # Stage events: every step entered once and ended once, in the study's order.
        events = list(
            session.scalars(
                select(StageEvent).where(StageEvent.participant_id == pid).order_by(StageEvent.id)
            )
        )
        entered = [(e.stage, e.step) for e in events if e.kind == "entered"]
        assert entered == expected_pages(study)
        ended = Counter((e.stage_index, e.step) for e in events if e.kind != "entered")
        assert set(ended.values()) == {1} and len(ended) == len(entered)
        per_model = [
            e.model
            for e in events
            if e.stage == "trial" and e.kind == "entered" and e.step == "run"
        ]
        assert per_model == list(order)

        # Trials: a training and a trial per model, in the participant's order, all ended,
        # each trial starting with the section the cell gives it.
        trials = list(
            session.scalars(select(Trial).where(Trial.participant_id == pid).order_by(Trial.id))
        )
        assert [(t.kind, t.model) for t in trials] == [
            (kind, model) for model in order for kind in ("training", "trial")
        ]
        assert all(latest_status(session, t.id) == "ended" for t in trials)
        for t in trials:
            assert t.duration_s == (
                study.timing.training_s if t.kind == "training" else study.timing.trial_s
            )
            if t.kind == "trial":
                assert t.first_section == enrolment.first_sections[t.model]
        assert session.scalars(
            select(Probe).where(Probe.trial_id.in_([t.id for t in trials]))
        ).first()

        items = list(
            session.scalars(
                select(QuestionnaireItem).where(QuestionnaireItem.participant_id == pid)
            )
        )
        by_instrument: dict[tuple[str, str], set[str]] = {}
        for row in items:
            by_instrument.setdefault((row.instrument, row.model), set()).add(row.item)
        assert by_instrument[("demographics", "")] == set(demographics.ITEM_KEYS)
        mrt_items = by_instrument[("mrt", "")]
        assert {f"mrt_{n:02d}" for n in range(1, 25)} <= mrt_items and len(mrt_items) == 28
        presentation = {f"{k}_{s}" for k in tlx.PAIR_KEYS for s in ("position", "left")}
        for model in ("M1", "M2", "M3"):
            assert by_instrument[("post_trial", model)] == set(post_trial.ITEM_KEYS)
            assert by_instrument[("sart", model)] == set(sart.ITEM_KEYS)
            assert by_instrument[("nasa_tlx", model)] == set(tlx.ITEM_KEYS) | presentation
            label = ranking.ORDER_LABELS[order.index(model)]
            assert by_instrument[("ranking", model)] == {
                f"{d.key}_{label}" for d in ranking.DIMENSIONS
            }
        assert len(items) == len({(r.instrument, r.model, r.item) for r in items}), (
            "an answer twice"
        )

        scores = {
            (s.instrument, s.model, s.scale): s.score
            for s in session.scalars(select(Score).where(Score.participant_id == pid))
        }
        assert 0 <= scores[("mrt", "", "total")] <= 24
        assert (
            scores[("mrt", "", "total")]
            == scores[("mrt", "", "part_1")] + scores[("mrt", "", "part_2")]
        )
        for model in ("M1", "M2", "M3"):
            assert 0 <= scores[("nasa_tlx", model, "overall")] <= 100
            assert -5 <= scores[("sart", model, "overall")] <= 13
            assert ("post_trial", model, "effectiveness") in scores
            assert {scores[("ranking", model, d.key)] for d in ranking.DIMENSIONS} <= {
                1.0,
                2.0,
                3.0,
            }
        code = participant.code

    # The export engineer's `hcss export` carries the study flow's rows.
    outdir = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(outdir), "--database-url", database_url])
    assert result.exit_code == 0, result.output
    participants = (outdir / "participants.csv").read_text()
    assert code in participants and ",completed," in participants
    exported_items = (outdir / "questionnaire_items.csv").read_text().splitlines()
    assert len(exported_items) - 1 == len(items)
    timings = (outdir / "stage_timings.csv").read_text().splitlines()[1:]
    stage_count = (
        len(study.sequence.before) + len(study.sequence.per_model) * 3 + len(study.sequence.after)
    )
    assert len(timings) == stage_count and all(line.startswith(code) for line in timings)
