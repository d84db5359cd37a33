"""A trial's time limit, its stream, and a refresh returning to the same trial."""

from __future__ import annotations

import json
import time
import uuid

from sqlalchemy import select

from hcss.platform.live.trials import latest_status
from hcss.platform.models import Probe, ProbeEvent, Snapshot, TrialStatusChange


def _frames(response, count: int) -> list[dict]:
    frames = []
    for chunk in response.response:
        for block in chunk.decode().split("\n\n"):
            data = [line[6:] for line in block.splitlines() if line.startswith("data: ")]
            if data:
                frames.append({"id": _event_id(block), **json.loads(data[0])})
        if len(frames) >= count:
            break
    response.close()
    return frames


def _event_id(block: str) -> int | None:
    ids = [line[4:] for line in block.splitlines() if line.startswith("id: ")]
    return int(ids[0]) if ids else None


def test_trial_ends_at_its_time_limit_with_no_browser_open(make_trial) -> None:
    trial = make_trial(kind="training", duration_s=120)
    trial.run_to(119)
    assert trial.state()["trial"]["status"] == "running"
    trial.run_to(500)  # the server's clock passes the deadline; nobody is watching
    with trial.app.extensions["hcss_db"].session_scope() as session:
        assert latest_status(session, trial.trial_id) == "ended"
        (end,) = session.scalars(
            select(TrialStatusChange).where(TrialStatusChange.status == "ended")
        ).all()
        assert (end.reason, end.step) == ("time_limit", 120)
        final = session.scalars(select(Snapshot).order_by(Snapshot.id.desc())).first()
        assert final.step == 120
        # Every probe shown is closed by the end (answered or timed out), none left dangling.
        shown = session.scalars(select(Probe).where(Probe.trial_id == trial.trial_id)).all()
        assert shown, "a two-minute trial shows at least one probe"
        for probe in shown:
            closing = session.scalars(
                select(ProbeEvent).where(
                    ProbeEvent.probe_id == probe.id, ProbeEvent.kind.in_(("answer", "timeout"))
                )
            ).all()
            assert len(closing) == 1 and closing[0].step <= 120, probe.id
    assert trial.client.get(trial.api + "/state").status_code == 409
    refused = trial.post("/requests", {"kind": "investigate", "collective": 0, "target": 1})
    assert refused.status_code == 409 and refused.get_json()["error"] == "ended"
    (frame,) = _frames(trial.client.get(trial.api + "/stream", buffered=False), 1)
    assert frame["trial"]["status"] == "ended"
    page = trial.client.get(f"/live/{trial.token}").get_data(as_text=True)
    assert 'data-status="ended"' in page


def test_training_has_two_collectives_and_five_minutes(make_trial) -> None:
    trial = make_trial(kind="training")
    state = trial.state()
    assert len(state["view"]["collectives"]) == 2
    assert state["trial"]["duration_s"] == 300


def test_stream_sends_state_at_least_twice_a_second_and_resumes_messages(make_trial) -> None:
    trial = make_trial()
    trial.run_to(40)
    response = trial.client.get(trial.api + "/stream", buffered=False)
    assert trial.app.config["STREAM_INTERVAL_S"] <= 0.5  # the 2 Hz floor
    started = time.monotonic()
    first, second, third = _frames(response, 3)
    # Nothing changes on the fake clock, yet frames keep coming. Only a loose wall-clock
    # bound (a broken wait would take STREAM_MAX_S): under -n 2 on a busy machine
    # a tight one races.
    assert time.monotonic() - started < 10.0
    assert first["view"]["collectives"] and first["trial"]["status"] == "running"
    targets = first["view"]["targets"]
    assert targets and all("true_value" not in t for t in targets)
    assert first["messages"] and first["id"] == first["messages"][-1]["seq"]
    assert second["messages"] == []  # each message is sent once
    seen = first["id"]
    trial.run_to(120)
    again = trial.client.get(
        trial.api + "/stream", headers={"Last-Event-ID": str(seen)}, buffered=False
    )
    (resumed,) = _frames(again, 1)
    assert resumed["messages"] and all(m["seq"] > seen for m in resumed["messages"])


def test_a_command_reaches_the_stream_without_waiting_for_a_step(make_trial) -> None:
    trial = make_trial()
    trial.run_to(60)
    target = next(t for t in trial.state()["view"]["targets"] if 0 in t["in_range_of"])
    response = trial.client.get(trial.api + "/stream", buffered=False)
    chunks = iter(response.response)
    next(chunks)  # retry
    before = json.loads(next(chunks).decode().split("data: ", 1)[1])
    assert before["view"]["requests"] == []
    trial.post("/requests", {"kind": "investigate", "collective": 0, "target": target["id"]})
    after = json.loads(next(chunks).decode().split("data: ", 1)[1])
    response.close()
    assert after["trial"]["step"] == before["trial"]["step"]
    assert [r["target"] for r in after["view"]["requests"]] == [target["id"]]


def test_refresh_returns_to_the_same_trial_at_its_current_time(make_trial) -> None:
    trial = make_trial()
    trial.run_to(200)
    page = trial.client.get(f"/live/{trial.token}").get_data(as_text=True)
    assert f"/trials/{trial.trial_id}/stream" in page
    assert trial.state()["trial"]["step"] == 200


def test_an_ended_trial_answers_ended_to_every_command_whatever_its_body(make_trial) -> None:
    """The live service finds the trial before it reads the body, so a clumsy client's
    garbage sent to a finished trial is told the trial has ended, not how to fix the body."""
    trial = make_trial(kind="training", duration_s=60)
    trial.run_to(500)
    headers = {"X-CSRFToken": trial.csrf, "Content-Type": "application/json"}
    for path in ("/requests", "/observations", "/probes/1/ready", "/probes/1/answer"):
        for body in ("not json", "[1, 2]", '{"kind": "investigate", "collective": 99}', ""):
            keyed = {**headers, "Idempotency-Key": uuid.uuid4().hex}
            refused = trial.client.post(trial.api + path, data=body, headers=keyed)
            assert refused.status_code == 409, (path, body, refused.get_data(as_text=True))
            assert refused.get_json()["error"] == "ended", (path, body)
