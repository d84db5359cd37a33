"""Replay tests' helpers: a scripted operator (many requests, accepted and refused, and probe
answers) and an uninterrupted replay of a trial's logged commands to compare a rebuild against."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.live.trial_log import build_simulation
from hcss.platform.models import Command, CommandOutcome, DecisionRow, Probe, ProbeEvent, Trial
from hcss.simulation import Display, Simulation
from hcss.simulation.operators import InvestigateThenDecide


def operate(trial: Any, until_s: float, *, from_s: float = 0.0, every_s: float = 4.0) -> int:
    """Drive a `TrialHandle` from `from_s` to `until_s` as a participant would; returns commands sent.

    Every few trial seconds: answer the probe on screen, send the policy's
    requests and one that the simulation must refuse (an unknown target).
    """
    policy = InvestigateThenDecide(abandon_below=0.3)
    sent = 0
    second = from_s
    while second + every_s < until_s:
        second += every_s
        trial.run_to(second)
        response = trial.client.get(trial.api + "/state")
        if response.status_code == 409:  # the trial has ended (and left the runner)
            break
        frame = response.get_json()
        if frame["trial"]["status"] == "ended":
            break
        probe = frame["probe"]
        if probe and probe["phase"] == "ready":
            trial.post(f"/probes/{probe['id']}/ready", {})
            choices = trial.state()["probe"]["choices"]
            trial.post(f"/probes/{probe['id']}/answer", {"answer": choices[0]})
        commands = [c.to_json() for c in policy.commands(Display.from_json(frame["view"]))[:3]]
        if int(second) % 20 == 0:
            commands.append(_undiscovered(frame["view"]))  # in range, refused by the simulation
        for command in commands:
            assert trial.post("/requests", command).status_code == 200
            sent += 1
    trial.run_to(until_s)
    return sent


def _undiscovered(view: dict) -> dict:
    """A decide on a target id the map does not show: valid input that the simulation refuses."""
    shown = {t["id"] for t in view["targets"]}
    target = next(i for i in range(1, 1000) if i not in shown)
    return {"kind": "decide", "collective": 1, "target": target}


def replay_trial(session: Session, trial_id: int, until_step: int) -> Simulation:
    """From the trial row at step 0, every logged command at its step, up to `until_step`.

    No snapshot is used (the platform's rebuild starts from one), so the two
    paths check each other: a snapshot that lost or changed state would make
    them differ.
    """
    trial = session.get(Trial, trial_id)
    assert trial is not None
    return build_simulation(session, trial, until_step)


def trial_records(database: Database, trial_id: int) -> dict[str, list[tuple]]:
    with database.session_scope() as session:
        commands = session.scalars(select(Command).where(Command.trial_id == trial_id))
        outcomes = session.execute(
            select(CommandOutcome).join(Command).where(Command.trial_id == trial_id)
        ).scalars()
        probes = session.scalars(select(Probe).where(Probe.trial_id == trial_id))
        probe_events = session.execute(
            select(ProbeEvent).join(Probe).where(Probe.trial_id == trial_id)
        ).scalars()
        decisions = session.scalars(select(DecisionRow).where(DecisionRow.trial_id == trial_id))
        return {
            "commands": [(c.id, c.kind, c.collective, c.target, c.step_applied) for c in commands],
            "outcomes": [(o.command_id, o.accepted, o.request_id, o.reason) for o in outcomes],
            "probes": [(p.id, p.level, p.question, p.truth) for p in probes],
            "probe_events": [(e.id, e.probe_id, e.kind, e.answer) for e in probe_events],
            "decisions": [(d.collective, d.decision_index, d.record["end_s"]) for d in decisions],
        }
