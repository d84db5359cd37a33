"""SA probes: schedule, SPAM flow (ready, then question), scoring, server-side time-out."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from sqlalchemy import select

from hcss.platform.live.probes import level_counts, probe_plan
from hcss.platform.models import Probe, ProbeEvent
from hcss.questionnaires.probes import PROBE_TIMEOUT_S, ProbeLevel
from hcss.simulation import ROMAN
from tests.support.trials import until_probe


def _events(app, probe_id: int) -> list[ProbeEvent]:
    with app.extensions["hcss_db"].session_scope() as session:
        return list(
            session.scalars(
                select(ProbeEvent).where(ProbeEvent.probe_id == probe_id).order_by(ProbeEvent.id)
            )
        )


def _probe_row(app, probe_id: int) -> Probe:
    with app.extensions["hcss_db"].session_scope() as session:
        return session.get(Probe, probe_id)


def test_a_20_minute_trial_plans_4_5_3_probes_about_one_a_minute() -> None:
    plan = probe_plan(seed=11, duration_s=1200)
    levels = [p.level for p in plan]
    assert (levels.count(1), levels.count(2), levels.count(3)) == (4, 5, 3)
    times = np.array([p.at_s for p in plan])
    assert np.all(np.diff(times) > PROBE_TIMEOUT_S)
    assert times[0] > 0 and times[-1] < 1200
    assert level_counts(300) == {ProbeLevel(1): 1, ProbeLevel(2): 1, ProbeLevel(3): 1}
    assert probe_plan(seed=11, duration_s=1200) == plan  # from the seed: same after a restart


def test_probe_flow_records_latencies_and_scores_against_the_simulation(make_trial) -> None:
    trial = make_trial(seed=4)
    probe, state, second = until_probe(trial, 0, level=ProbeLevel.PERCEPTION)
    assert probe["phase"] == "ready" and probe["question"] is None and probe["choices"] is None
    assert probe["subject"] is None  # the question, and what it is about, wait for Ready
    row = _probe_row(trial.app, probe["id"])
    target_id = int(row.question.rsplit(" ", 1)[1].rstrip("?"))
    assert any(t["id"] == target_id for t in state["view"]["targets"])
    # Truth at the moment of asking (nothing has stepped since): the collective with the
    # most agents favouring the target, counted from the agents themselves, not from the
    # view's support the probe is filled from.
    world = trial.live().sim.world
    favouring = world.favouring() & (world.target == target_id - 1)
    agents = [int(np.sum(favouring & (world.collective == c))) for c in range(world.n_collectives)]
    assert max(agents) > 0
    assert row.truth == ROMAN[agents.index(max(agents))]
    assert "truth" not in probe

    # Answering before "ready" is refused; "ready" reveals the question.
    early = trial.post(f"/probes/{probe['id']}/answer", {"answer": row.truth})
    assert early.status_code == 409
    trial.run_to(second + 4)
    assert trial.post(f"/probes/{probe['id']}/ready", {}).status_code == 200
    shown = trial.state()["probe"]
    assert shown["phase"] == "question" and shown["question"] == row.question
    assert shown["choices"] == ["I", "II", "III", "IV"]
    assert shown["subject"] == {"target": target_id}  # the page keeps the box off it
    assert trial.post(f"/probes/{probe['id']}/answer", {"answer": "V"}).status_code == 400
    trial.run_to(second + 10)
    wrong = next(c for c in shown["choices"] if c != row.truth)
    assert trial.post(f"/probes/{probe['id']}/answer", {"answer": wrong}).status_code == 200
    assert trial.state()["probe"] is None
    again = trial.post(f"/probes/{probe['id']}/answer", {"answer": row.truth})
    assert again.status_code == 409  # one answer per probe

    ready, answer, scored = _events(trial.app, probe["id"])
    assert (ready.kind, answer.kind, scored.kind) == ("ready", "answer", "scored")
    assert ready.sim_time - row.shown_sim_time == pytest.approx(4, abs=1)
    assert answer.answer == wrong and scored.truth == row.truth and scored.correct is False


def test_comprehension_truth_is_the_best_target(make_trial) -> None:
    trial = make_trial(seed=4)
    probe, _state, _second = until_probe(trial, 0, level=ProbeLevel.COMPREHENSION)
    row = _probe_row(trial.app, probe["id"])
    collective = ROMAN.index(row.question.rsplit(" ", 1)[1].rstrip("?"))
    # Independently of Simulation.best_target: of the targets offered (those in range)
    # that the collective may choose (under the default reading foreign_targets="own_only",
    # those placed around its own start hub), the highest true value, the nearer on a tie.
    sim = trial.live().sim
    world = sim.world
    offered = [int(choice) for choice in row.choices]
    if sim.params.foreign_targets == "own_only":
        offered = [t for t in offered if world.target_around[t - 1] == collective]
    best = min(
        offered,
        key=lambda t: (-world.target_value[t - 1], world.hub_distance[collective, t - 1]),
    )
    assert row.truth == str(best)
    trial.post(f"/probes/{probe['id']}/ready", {})
    assert row.truth in trial.state()["probe"]["choices"]
    trial.post(f"/probes/{probe['id']}/answer", {"answer": row.truth})
    *_, scored = _events(trial.app, probe["id"])
    assert scored.kind == "scored" and scored.correct is True


def test_unanswered_probe_times_out_on_the_server(make_trial) -> None:
    trial = make_trial(seed=4)
    probe, _state, second = until_probe(trial, 0)
    trial.run_to(second + PROBE_TIMEOUT_S - 1)
    assert trial.state()["probe"]["id"] == probe["id"]
    trial.run_to(second + PROBE_TIMEOUT_S + 1)
    assert trial.state()["probe"] is None
    (timeout,) = _events(trial.app, probe["id"])
    assert timeout.kind == "timeout"
    late = trial.post(f"/probes/{probe['id']}/ready", {})
    assert late.status_code == 409


def test_projection_is_scored_when_the_next_decision_happens(make_trial) -> None:
    # M2: its decisions take minutes, so the trial is still running when the next
    # decision after a late projection probe comes (M1 may have finished all 12).
    trial = make_trial(seed=4, model="M2")
    probe, _state, second = until_probe(trial, 0, level=ProbeLevel.PROJECTION)
    assert _probe_row(trial.app, probe["id"]).truth is None
    trial.post(f"/probes/{probe['id']}/ready", {})
    trial.post(f"/probes/{probe['id']}/answer", {"answer": "II"})
    decisions_before = len(trial.live().sim.decisions)
    while len(trial.live().sim.decisions) == decisions_before:
        second += 5
        assert second < 1200, "no decision after the projection probe"
        trial.run_to(second)
    decision = trial.live().sim.decisions[decisions_before]
    answer, scored = _events(trial.app, probe["id"])[-2:]
    assert answer.kind == "answer" and answer.correct is None
    assert scored.kind == "scored" and scored.truth == ROMAN[decision.collective]
    assert scored.correct is (ROMAN[decision.collective] == "II")


def test_latencies_are_wall_clock_milliseconds_from_delivery(
    make_trial, database_url, tmp_path
) -> None:
    """Sub-second answers keep their milliseconds (they were whole simulation seconds,
    exported as 0.0), and an experimenter's pause in between does not count."""
    from click.testing import CliRunner

    from hcss.cli import main
    from hcss.platform.console.interventions import change_participant_state
    from hcss.platform.models import Participant

    trial = make_trial(seed=4)
    probe, _, _ = until_probe(trial, 0)  # this state() read delivered the prompt
    clock = trial.runner.clock
    clock.now += 0.250
    assert trial.post(f"/probes/{probe['id']}/ready", {}).status_code == 200
    clock.now += 0.100
    choice = trial.state()["probe"]["choices"][0]  # the question is delivered now
    clock.now += 0.200
    with trial.app.app_context():
        with trial.app.extensions["hcss_db"].session_scope() as session:
            participant = session.scalars(
                select(Participant).where(Participant.token == trial.token)
            ).one()
            session.expunge(participant)
        change_participant_state(
            trial.app.extensions["hcss_db"],
            trial.app.extensions["hcss_live"],
            participant,
            None,
            "pause",
        )
        clock.now += 5.0  # the pause: wall time that is no one's latency
        change_participant_state(
            trial.app.extensions["hcss_db"],
            trial.app.extensions["hcss_live"],
            participant,
            None,
            "resume",
        )
    clock.now += 0.133
    assert trial.post(f"/probes/{probe['id']}/answer", {"answer": choice}).status_code == 200

    ready, answer = (e for e in _events(trial.app, probe["id"]) if e.kind in ("ready", "answer"))
    assert ready.latency_ms == pytest.approx(250.0, abs=0.1)
    assert answer.latency_ms == pytest.approx(333.0, abs=0.1)

    out = tmp_path / "export"
    result = CliRunner().invoke(main, ["export", str(out), "--database-url", database_url])
    assert result.exit_code == 0, result.output
    with (out / "probes.csv").open() as handle:
        row = next(r for r in csv.DictReader(handle) if r["probe_index"] == str(probe["index"]))
    assert (float(row["ready_latency_ms"]), float(row["answer_latency_ms"])) == (250.0, 333.0)
    # 333 ms is quicker than anyone reads a question: flagged (the study file's 1000 ms).
    assert row["fast_answer"] == "true"


def test_the_fast_answer_threshold_is_a_checked_study_setting() -> None:
    import tomllib

    from hcss.platform.study.files import study_text
    from hcss.platform.study.studyfile import StudyFileError, load_study, parse_study

    assert load_study("original").probes.fast_answer_ms == 1000
    doc = tomllib.loads(study_text("demo")[1].decode())
    doc["probes"]["fast_answer_ms"] = 600
    assert parse_study(doc, source="demo.toml").probes.fast_answer_ms == 600
    doc["probes"]["fast_answer_ms"] = -5
    with pytest.raises(StudyFileError, match="probes.fast_answer_ms"):
        parse_study(doc, source="demo.toml")


def test_the_study_files_probe_counts_reach_the_runner_and_survive_a_rebuild(
    app, make_trial
) -> None:
    """A study asking 2/0/1 probes per 20 minutes gets exactly that, before and after a restart."""
    trial = make_trial(seed=11, duration_s=1200.0, probe_counts={1: 2, 2: 0, 3: 1})
    runner = app.extensions["hcss_runner"]
    levels = [p.level for p in runner.host(trial.trial_id).probes.plan]
    assert sorted(levels) == [1, 1, 3]
    runner.forget(trial.trial_id)  # rebuilt from the database: the trial row keeps the counts
    assert [p.level for p in runner.host(trial.trial_id).probes.plan] == levels
    default = make_trial(seed=11, duration_s=1200.0)
    assert len(runner.host(default.trial_id).probes.plan) == 12


def test_a_study_file_with_other_probe_counts_is_accepted_and_bad_ones_refused() -> None:
    import tomllib

    from hcss.platform.study.files import study_text
    from hcss.platform.study.studyfile import StudyFileError, parse_study

    doc = tomllib.loads(study_text("original")[1].decode())
    doc["probes"] = {"perception": 2, "comprehension": 0, "projection": 1}
    assert parse_study(doc, source="t").probes.per_level == {1: 2, 2: 0, 3: 1}
    for bad in (-1, 10**6):
        doc["probes"]["projection"] = bad
        with pytest.raises(StudyFileError, match=r"\[probes\]"):
            parse_study(doc, source="t")


def test_a_probe_with_no_subject_until_the_end_is_still_asked(make_trial, monkeypatch) -> None:
    """A 2-minute demo trial plans one probe. Postponed while no collective or target made
    sense for its level, it was postponed past the trial's end: one demo trial in three had
    no probe, though the consent promises one about every minute or two. With too little
    time left to look again, the level that always has a subject (projection) is asked."""
    import hcss.platform.live.recorder as recorder

    real_fill = recorder.fill_probe

    def nothing_to_ask_about_yet(level, display, truth, rng):
        if level != ProbeLevel.PROJECTION:
            return None  # e.g. no target supported yet, no collective with two in range
        return real_fill(level, display, truth, rng)

    monkeypatch.setattr(recorder, "fill_probe", nothing_to_ask_about_yet)
    for seed in range(3):
        trial = make_trial(seed=seed, duration_s=120.0)
        (planned,) = trial.live().probes.plan
        shown = []
        for second in range(2, 121, 2):
            trial.run_to(float(second))
            live = trial.live()
            if live is None:  # the trial ended
                break
            if live.probes.current is not None:
                shown.append((second, live.probes.current.level))
                break
        assert shown, f"seed {seed}: the planned level-{planned.level} probe was never asked"
        at, level = shown[0]
        assert at <= 120 - PROBE_TIMEOUT_S + 2  # with its time-out's time left to answer
        assert level == ProbeLevel.PROJECTION
