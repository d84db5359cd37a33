"""Operator policies: simple scripted operators for tests and batch runs.

A policy looks at what the interface shows (`Simulation.display()`, or
`Display.from_json` of a stream frame for a bot) every so often and issues
`OperatorCommand`s, as a participant would. Each command is logged with the
step at which it was applied, so a run with an operator can be replayed exactly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from hcss.simulation.engine import Simulation
from hcss.simulation.replay import TimedCommand
from hcss.simulation.requests import IN_PROGRESS, OperatorCommand
from hcss.simulation.view import Display


class OperatorPolicy(Protocol):
    def commands(
        self, display: Display, collectives: Sequence[int] | None = None
    ) -> list[OperatorCommand]:
        """The requests to make now about `collectives` (all if None), given what is shown."""
        ...


@dataclass
class Passive:
    """Makes no requests: the simulation-only condition."""

    def commands(
        self, display: Display, collectives: Sequence[int] | None = None
    ) -> list[OperatorCommand]:
        return []


@dataclass
class InvestigateThenDecide:
    """Investigate the best-looking visible target in range; decide once support allows.

    `decide_support` is the support at which it decides (the simulation
    refuses below 30%). With `abandon_below` it abandons targets whose shown
    value is that far below the best, when at least `abandon_supporters`
    agents favour them (the simulation refuses fewer: `Params.abandon_min_supporters`).
    """

    decide_support: float = 0.30
    abandon_below: float | None = None
    abandon_supporters: int = 2

    def commands(
        self, display: Display, collectives: Sequence[int] | None = None
    ) -> list[OperatorCommand]:
        d = display
        issued: list[OperatorCommand] = []
        for c in range(d.n_collectives) if collectives is None else collectives:
            if d.executing[c]:
                continue
            in_range = np.flatnonzero(d.in_range[c] & d.drawn)
            if not in_range.size:
                continue
            best = int(in_range[np.argmax(d.value[in_range])])
            best_id = int(d.target_ids[best])
            if d.support[c, best] >= self.decide_support:
                issued.append(OperatorCommand("decide", c, best_id))
                continue
            busy = any(
                r.collective == c and r.kind == "investigate" and r.status == IN_PROGRESS
                for r in d.requests
            )
            if not busy:
                issued.append(OperatorCommand("investigate", c, best_id))
            if self.abandon_below is not None:
                abandoning = {
                    r.target for r in d.requests if r.collective == c and r.kind == "abandon"
                }
                for v in in_range.tolist():
                    weak = d.value[v] < d.value[best] - self.abandon_below
                    supporters = d.support[c, v] * d.n_agents
                    target = int(d.target_ids[v])
                    if weak and supporters >= self.abandon_supporters and target not in abandoning:
                        issued.append(OperatorCommand("abandon", c, target))
        return issued


@dataclass(frozen=True)
class HumanPace:
    """A human operator's pace, for piloting a design before recruiting.

    - `glance_interval_s`: how often the operator looks at the interface.
    - `reaction_time_s`: from a glance to its requests reaching the
      simulation (reading, deciding, clicking through the form). The study's
      interface needs a target click, a collective click and a confirm; a
      few seconds is a plausible order [choice].
    - `one_collective_at_a_time`: attention to one collective per glance; the
      operator turns to the next collective (round robin) at the next glance.
    - `requests_per_minute`: a bound on the rate of requests (a token bucket
      holding one minute's worth); requests beyond it wait their turn.
    """

    glance_interval_s: float = 5.0
    reaction_time_s: float = 3.0
    one_collective_at_a_time: bool = True
    requests_per_minute: float = 8.0

    def __post_init__(self) -> None:
        if self.glance_interval_s <= 0 or self.reaction_time_s < 0 or self.requests_per_minute <= 0:
            raise ValueError("a pace needs a positive glance interval and request rate")


@dataclass
class OperatedRun:
    """A simulation driven by a policy, with the log of every command and its outcome.

    Without a `pace` the policy acts every `interval_s` with no delay, on every
    collective. With a `HumanPace` it glances every `pace.glance_interval_s`,
    at one collective at a time if so set, its requests arrive
    `pace.reaction_time_s` later and at most `pace.requests_per_minute`. Either
    way every command goes through `Simulation.apply`, the request API of a
    live trial, and lands in the same decision records.
    """

    sim: Simulation
    policy: OperatorPolicy
    interval_s: float = 10.0
    pace: HumanPace | None = None
    log: list[TimedCommand] = field(default_factory=list)
    refusals: list[tuple[int, OperatorCommand, str]] = field(default_factory=list)
    _queue: list[tuple[float, OperatorCommand]] = field(default_factory=list)
    _focus: int = 0
    _tokens: float = 0.0

    def run(self, until_s: float | None = None) -> Simulation:
        dt = self.sim.params.dt_s
        glance = self.pace.glance_interval_s if self.pace else self.interval_s
        every = max(1, round(glance / dt))
        if self.pace:
            self._tokens = self.pace.requests_per_minute
        while not self.sim.finished and (until_s is None or self.sim.time < until_s):
            if self.sim.step_count % every == 0:
                self._glance()
            self._send_due()
            self.sim.step()
            if self.pace:
                self._tokens = min(
                    self.pace.requests_per_minute,
                    self._tokens + self.pace.requests_per_minute * dt / 60.0,
                )
        return self.sim

    def _glance(self) -> None:
        display = self.sim.display()
        focus = None
        if self.pace and self.pace.one_collective_at_a_time and display.n_collectives:
            focus = [self._focus % display.n_collectives]
            self._focus += 1
        delay = self.pace.reaction_time_s if self.pace else 0.0
        pending = {c.key() for _, c in self._queue}
        for command in self.policy.commands(display, focus):
            if command.key() not in pending:  # a human does not click twice
                self._queue.append((self.sim.time + delay, command))

    def _send_due(self) -> None:
        while self._queue and self._queue[0][0] <= self.sim.time + 1e-9:
            if self.pace and self._tokens < 1.0:
                return
            _, command = self._queue.pop(0)
            if self.pace:
                self._tokens -= 1.0
            outcome = self.sim.apply(command)
            self.log.append((self.sim.step_count, command))
            if not outcome.accepted:
                self.refusals.append((self.sim.step_count, command, outcome.reason))


def operator_named(name: str) -> tuple[OperatorPolicy, float, HumanPace | None]:
    """A scripted operator by name: (policy, interval without pace, pace or None).

    - "investigate-then-decide": investigates the best-looking target, decides
      at 30% support, abandons targets shown 0.15 below the best; acts every
      10 s on every collective at once, with no delay (an upper bound on a
      human's speed).
    - "human": the same policy at a human's pace (`HumanPace()` defaults).
    """
    if name not in OPERATORS:
        raise ValueError(f"operator must be one of {', '.join(OPERATORS)}, not {name!r}")
    policy = InvestigateThenDecide(abandon_below=0.15)
    if name == "human":
        return policy, 10.0, HumanPace()
    return policy, 10.0, None


OPERATORS: tuple[str, ...] = ("investigate-then-decide", "human")
