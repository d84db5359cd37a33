"""Replay in the console: a recorded trial rebuilt from its seed, scenario and command log."""

from __future__ import annotations

import re

import pytest
from sqlalchemy import select

from hcss.platform.models import (
    Command,
    CommandOutcome,
    Interruption,
    Participant,
    Snapshot,
    Trial,
)
from hcss.simulation import Simulation
from tests.support.console import code_of
from tests.support.replays import operate, replay_trial


def _final_snapshot_digest(app, trial_id: int) -> str:
    with app.extensions["hcss_db"].session_scope() as session:
        snapshot = session.scalars(
            select(Snapshot).where(Snapshot.trial_id == trial_id).order_by(Snapshot.id.desc())
        ).first()
        return Simulation.restore(snapshot.blob).state_digest()


def _all_frames(console, trial_id: int, count: int = 50) -> tuple[list[dict], dict]:
    """Every frame, fetched in chunks as the page does; and the last chunk's head."""
    frames: list[dict] = []
    while True:
        response = console.get(
            f"/console/trials/{trial_id}/replay/frames?start={len(frames)}&count={count}"
        )
        assert response.status_code == 200, response.get_data(as_text=True)
        body = response.get_json()
        assert body["start"] == len(frames)
        frames += body["frames"]
        if len(frames) > body["horizon"]:
            return frames, body


def test_a_finished_trial_replays_to_the_recorded_end_state(app, make_trial, console) -> None:
    trial = make_trial(seed=7, duration_s=180.0)
    sent = operate(trial, 90.0)
    # An interruption midway (the runner lets go and rebuilds from a snapshot) changes nothing.
    trial.runner.forget(trial.trial_id)
    sent += operate(trial, 180.0, from_s=90.0)
    # The rebuild's outage is excluded from the trial clock, so the trial ends a little later.
    trial.run_to(200.0)
    assert sent >= 10
    frames, last = _all_frames(console, trial.trial_id)
    assert last["ended"] and last["horizon"] == 180 and len(frames) == 181
    recorded = _final_snapshot_digest(app, trial.trial_id)
    assert last["replayed_digest"] == last["recorded_digest"] == recorded
    with app.extensions["hcss_db"].session_scope() as session:
        independent = replay_trial(session, trial.trial_id, 180)
        interruptions = len(session.scalars(select(Interruption)).all())
        accepted = session.scalars(
            select(Command)
            .join(CommandOutcome, CommandOutcome.command_id == Command.id)
            .where(Command.trial_id == trial.trial_id, CommandOutcome.accepted)
            .order_by(Command.id)
        ).all()
    assert independent.state_digest() == recorded
    assert interruptions == 1
    # The frames are the participant's view at each step: no true values, the requests listed.
    assert all("true_value" not in t for f in frames for t in f["targets"])
    first = accepted[0]
    assert any(r["kind"] == first.kind for r in frames[first.step_applied]["requests"])
    assert frames[0] != frames[-1]


def test_the_timeline_marks_requests_probe_answers_and_messages(app, make_trial, console) -> None:
    trial = make_trial(seed=7, duration_s=180.0)
    sent = operate(trial, 180.0)
    body = console.get(f"/console/trials/{trial.trial_id}/replay/timeline").get_json()
    assert len(body["commands"]) == sent
    refused = [c for c in body["commands"] if c["accepted"] is False]
    assert refused and all(c["reason"] for c in refused)
    assert any(
        re.fullmatch(
            r"(There is no target \d+|Target \d+ has not been discovered yet)\.", c["reason"]
        )
        for c in refused
    )
    assert any(c["accepted"] for c in body["commands"])
    answered = [p for p in body["probes"] if not p["timed_out"]]
    assert answered and all(p["answer"] is not None and p["ready"] is not None for p in answered)
    assert all(p["shown"] <= p["closed"] for p in body["probes"])
    times = [m["time"] for m in body["messages"]]
    assert times == sorted(times) and any(m["kind"] == "refusal" for m in body["messages"])
    # The System Messages the participant saw, "Request N accepted" lines included.
    accepted = [m["text"] for m in body["messages"] if m["kind"] == "accepted"]
    assert len(accepted) == sum(1 for c in body["commands"] if c["accepted"])
    assert all(re.match(r"Request (\d+ )?accepted \(", text) for text in accepted), accepted
    assert body["trial"]["dt"] == 1.0 and body["trial"]["duration_s"] == 180.0


def test_a_live_trial_replays_up_to_its_newest_snapshot(app, make_trial, console) -> None:
    trial = make_trial(seed=11, duration_s=300.0)
    operate(trial, 60.0)
    frames, first = _all_frames(console, trial.trial_id)
    assert not first["ended"] and first["horizon"] <= 60
    assert first["replayed_digest"] == first["recorded_digest"]
    # The trial goes on; the cached replay continues with the newer commands.
    operate(trial, 150.0, from_s=60.0)
    trial.runner.forget(trial.trial_id)  # a restart: rebuilt from its snapshot
    trial.run_to(155.0)
    more, later = _all_frames(console, trial.trial_id)
    assert later["horizon"] > first["horizon"] and more[: len(frames)] == frames
    assert later["replayed_digest"] == later["recorded_digest"]


def test_the_participant_page_links_each_trial_to_its_replay(app, make_trial, console) -> None:
    trial = make_trial(seed=3, duration_s=30.0)
    trial.run_to(30.0)
    page = console.get(f"/console/participants/{code_of(app, trial.token)}").get_data(as_text=True)
    assert f'href="/console/trials/{trial.trial_id}/replay"' in page
    replay = console.get(f"/console/trials/{trial.trial_id}/replay").get_data(as_text=True)
    assert 'data-status="replay"' in replay and "replay.js" in replay and "live.js" in replay
    assert trial.token not in replay  # a console page never carries a participant's key


@pytest.mark.parametrize(
    "query",
    ["start=-1", "start=abc", "count=1e9", "start=99999999999", "start=%00", "count=" + "9" * 400],
)
def test_bad_frame_requests_are_refused(app, make_trial, console, query: str) -> None:
    trial = make_trial(seed=3, duration_s=30.0)
    response = console.get(f"/console/trials/{trial.trial_id}/replay/frames?{query}")
    assert response.status_code == 400
    # A NUL byte is refused by the hardening layer before the route (an HTML error page).
    assert response.is_json is False or response.get_json()["error"] == "bad_request"


def test_replay_is_for_signed_in_experimenters_only(app, make_trial, console) -> None:
    trial = make_trial(seed=3, duration_s=30.0)
    for path in ("", "/timeline", "/frames"):
        anonymous = app.test_client().get(f"/console/trials/{trial.trial_id}/replay{path}")
        assert anonymous.status_code == 302 and "/console/login" in anonymous.location
    for missing in (0, 424242, 2**31, 10**30):
        assert console.get(f"/console/trials/{missing}/replay").status_code == 404
    with app.extensions["hcss_db"].session_scope() as session:
        assert session.scalar(select(Trial.participant_id)) is not None
        assert session.scalars(select(Participant)).first() is not None
