"""A scripted operator for replay tests: many requests, accepted and refused, and probe answers."""

from __future__ import annotations

from typing import Any

from hcss.simulation import Display
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
