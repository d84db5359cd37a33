"""Operator policies: simple scripted operators for tests and batch runs.

A policy looks at what the interface shows (`sim.view()`) every so often and
issues requests, as a participant would. Each command is logged with the step
at which it was applied, so a run with an operator can be replayed exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from hcss.simulation.engine import Simulation
from hcss.simulation.replay import TimedCommand


class OperatorPolicy(Protocol):
    def commands(self, view: dict) -> list[dict]:
        """The requests to make now, given what the interface shows."""
        ...


@dataclass
class Passive:
    """Makes no requests: the simulation-only condition."""

    def commands(self, view: dict) -> list[dict]:
        return []


@dataclass
class InvestigateThenDecide:
    """Investigate the best-looking visible target in range; decide once support allows.

    `decide_support` is the support at which it decides (the simulation
    refuses below 30%).
    """

    decide_support: float = 0.30
    abandon_below: float | None = (
        None  # abandon targets whose shown value is this far below the best
    )

    def commands(self, view: dict) -> list[dict]:
        requests = view["requests"]
        issued: list[dict] = []
        for collective in view["collectives"]:
            c = collective["index"]
            if collective["executing"]:
                continue
            in_range = [t for t in view["targets"] if c in t["in_range_of"] and t["drawn"]]
            if not in_range:
                continue
            best = max(in_range, key=lambda t: t["value"])
            if best["support"][c] >= self.decide_support:
                issued.append({"kind": "decide", "collective": c, "target": best["id"]})
                continue
            busy = any(
                r["collective"] == c and r["kind"] == "investigate" and r["status"] == "in_progress"
                for r in requests
            )
            if not busy:
                issued.append({"kind": "investigate", "collective": c, "target": best["id"]})
            if self.abandon_below is not None:
                abandoning = {
                    r["target"] for r in requests if r["collective"] == c and r["kind"] == "abandon"
                }
                for t in in_range:
                    weak = t["value"] < best["value"] - self.abandon_below
                    if weak and t["support"][c] * 200 >= 2 and t["id"] not in abandoning:
                        issued.append({"kind": "abandon", "collective": c, "target": t["id"]})
        return issued


@dataclass
class OperatedRun:
    """A simulation driven by a policy, with the log of every command and its outcome."""

    sim: Simulation
    policy: OperatorPolicy
    interval_s: float = 10.0
    log: list[TimedCommand] = field(default_factory=list)
    refusals: list[tuple[int, dict, str]] = field(default_factory=list)

    def run(self, until_s: float | None = None) -> Simulation:
        every = max(1, round(self.interval_s / self.sim.params.dt_s))
        while not self.sim.finished and (until_s is None or self.sim.time < until_s):
            if self.sim.step_count % every == 0:
                for command in self.policy.commands(self.sim.view()):
                    outcome = self.sim.apply(command)
                    self.log.append((self.sim.step_count, command))
                    if not outcome.accepted:
                        self.refusals.append((self.sim.step_count, command, outcome.reason))
            self.sim.step()
        return self.sim
