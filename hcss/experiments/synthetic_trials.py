"""A synthetic participant's trial in process: the operator's path through `Simulation.apply`.

The same `SyntheticOperator` that the HTTP bot drives (`hcss.platform.bots.synthetic`)
looks at `Simulation.display()` at its glance steps and its clicks land
`reaction_steps` later, at step boundaries, as a live trial applies commands.
SA probes come from the live platform's own plan and filling (`hcss.sa_probes`,
seeded from the trial's seed as the live recorder seeds them), are answered
from the operator's memory and scored as the platform scores them (level 3 by
the next decision to end after the probe showed).

A trial ends at the study's time limit (`duration_s`), whatever is under way,
or when its 12 decisions are made; as in a live trial, decisions have no
per-decision time-out. Rows come out as the export's tables have them, with
`source = "synthetic"` on the decisions, so `hcss analyze` reads them as it
reads a study's export and never pools them with real participants unasked.
"""

from __future__ import annotations

import heapq
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hcss.questionnaires.probes import PROBE_TIMEOUT_S, ProbeLevel
from hcss.sa_probes import POSTPONE_S, fill_probe, probe_plan
from hcss.simulation.engine import Simulation
from hcss.simulation.messages import collective_name
from hcss.simulation.params import Params
from hcss.simulation.requests import OperatorCommand
from hcss.simulation.scenario import Scenario
from hcss.simulation.synthetic import ObservationClick, SyntheticOperator, Traits

SYNTHETIC = "synthetic"  # the decisions table's `source` of a synthetic participant's trials
TRIAL_S = 1200.0  # the original protocol's trial length (the study file's timing.trial_s)


@dataclass
class TrialRows:
    """One trial's rows, table by table, as the export writes them."""

    decisions: list[dict[str, Any]] = field(default_factory=list)
    requests: list[dict[str, Any]] = field(default_factory=list)
    observations: list[dict[str, Any]] = field(default_factory=list)
    probes: list[dict[str, Any]] = field(default_factory=list)

    def extend(self, other: TrialRows) -> None:
        for name in ("decisions", "requests", "observations", "probes"):
            getattr(self, name).extend(getattr(other, name))

    def participant_of(self) -> dict[str, str]:
        """Each trial's participant, from every table: a trial whose collectives made no
        decision still has its probes and clicks, and its participant their cells."""
        return {
            str(row["trial_id"]): str(row["participant"])
            for name in ("decisions", "requests", "observations", "probes")
            for row in getattr(self, name)
        }


def glance_steps(operator: SyntheticOperator, dt_s: float, duration_s: float) -> list[int]:
    """The steps at which the operator looks: its glance times rounded to steps, once each.

    One schedule for both paths: the HTTP bot moves the trial's clock to these steps.
    """
    steps = sorted({max(1, round(t / dt_s)) for t in operator.glance_times(duration_s)})
    return [s for s in steps if s * dt_s < duration_s]


def reaction_steps(traits: Traits, dt_s: float) -> int:
    """Steps from a look to its clicks landing (at least one: a click follows the look)."""
    return max(1, round(traits.reaction_time_s / dt_s))


def run_trial(
    scenario: Scenario,
    model: str,
    params: Params,
    operator: SyntheticOperator,
    participant: str,
    trial_id: str,
    duration_s: float = TRIAL_S,
    probes: bool = True,
) -> tuple[Simulation, TrialRows]:
    """Run one operated trial to its time limit; the simulation and its rows."""
    params = params.with_changes(decision_timeout_s=None)
    sim = Simulation(scenario, model, params)
    dt = params.dt_s
    react = reaction_steps(operator.traits, dt)
    last_step = int(round(duration_s / dt))
    queue: list[tuple[int, int, str, Any]] = []  # (step, order, kind, payload)
    order = 0

    def push(step: int, kind: str, payload: Any) -> None:
        nonlocal order
        heapq.heappush(queue, (step, order, kind, payload))
        order += 1

    for step in glance_steps(operator, dt, duration_s):
        push(step, "look", None)
    plan = probe_plan(scenario.seed, duration_s) if probes else []
    for index, planned in enumerate(plan, start=1):
        push(max(1, int(-(-planned.at_s // dt))), "probe", (index, planned.level))
    rows = TrialRows()
    asked: list[dict[str, Any]] = []
    base = {"participant": participant, "trial_id": trial_id, "model": model}
    while queue:
        step, _, kind, payload = heapq.heappop(queue)
        if step >= last_step:
            break
        if step > sim.step_count:
            sim.step(step - sim.step_count)
        if sim.finished:
            break
        if kind == "look":
            glance = operator.look(sim.display())
            for command in glance.commands:
                push(step + react, "command", command)
            for click in glance.observations:
                push(step + react, "observe", (click, glance.collective))
        elif kind == "command":
            rows.requests.append(_request_row(base, sim, payload))
        elif kind == "observe":
            click, attended = payload
            if click.kind == "collective" or sim.display().column(click.target) is not None:
                rows.observations.append(_observation_row(base, sim.time, click, attended))
            # else the target has left the map since the look: the click lands on nothing
        elif kind == "probe":
            index, level = payload
            probe = _ask(sim, operator, index, level, duration_s, dt)
            if probe is None:
                push(step + max(1, round(POSTPONE_S / dt)), "probe", payload)
            else:
                asked.append(base | probe)
    rows.decisions = [
        d.as_row(source=SYNTHETIC, participant=participant, trial_id=trial_id, run=0)
        for d in sim.decisions
    ]
    rows.probes = [_scored(probe, sim) for probe in asked]
    return sim, rows


def _request_row(base: dict[str, Any], sim: Simulation, command: OperatorCommand) -> dict[str, Any]:
    time = sim.time
    outcome = sim.apply(command)
    return base | {
        "sim_time_s": time,
        "request_id": outcome.request_id,
        "kind": command.kind,
        "collective": None if command.collective is None else collective_name(command.collective),
        "target": command.target,
        "accepted": outcome.accepted,
        "reason": outcome.reason,
        "support": outcome.support,
        "intervention": outcome.intervention,
        "decision_index": outcome.decision_index,
    }


def _observation_row(
    base: dict[str, Any], time: float, click: ObservationClick, attended: int | None
) -> dict[str, Any]:
    """The export's row, and `attended`: the collective the operator was looking at (not
    exported; `study_teams` counts a target click for that collective's decision)."""
    return base | {
        "sim_time_s": time,
        "kind": click.kind,
        "collective": None if click.collective is None else collective_name(click.collective),
        "target": click.target,
        "button": click.button,
        "attended": None if attended is None else collective_name(attended),
    }


def _ask(
    sim: Simulation,
    operator: SyntheticOperator,
    index: int,
    level: int,
    duration_s: float,
    dt: float,
) -> dict[str, Any] | None:
    """Fill a due probe as the live recorder does and take the operator's answer, or None
    when no subject makes sense yet (the caller asks again `POSTPONE_S` later)."""
    rng = np.random.default_rng([sim.scenario.seed, 0x5B, index])
    display, truth = sim.display(), sim.truth()
    filled = fill_probe(level, display, truth, rng)
    if filled is None and sim.time + POSTPONE_S + PROBE_TIMEOUT_S > duration_s:
        filled = fill_probe(ProbeLevel.PROJECTION, display, truth, rng)
    if filled is None:
        return None
    t = operator.traits
    latency = t.probe_ready_s + t.probe_answer_s
    timed_out = latency >= PROBE_TIMEOUT_S or sim.time + latency >= duration_s
    answer = "" if timed_out else operator.answer(filled.level, filled.question, filled.choices)
    return {
        "sim_time_s": sim.time,
        "probe_index": index,
        "level": filled.level,
        "question": filled.question,
        "ready_latency_ms": None if timed_out else round(1000 * t.probe_ready_s),
        "answer_latency_ms": None if timed_out else round(1000 * t.probe_answer_s),
        "answer": answer,
        "truth": filled.truth,
        "timed_out": timed_out,
        "fast_answer": False,
    }


def _scored(probe: dict[str, Any], sim: Simulation) -> dict[str, Any]:
    """The probe with its truth and correctness; a projection's truth is the collective of
    the first decision to end after it showed (none: unscored, as a live trial leaves it)."""
    truth = probe["truth"]
    if probe["level"] == ProbeLevel.PROJECTION:
        later = [d for d in sim.decisions if d.end_s > probe["sim_time_s"]]
        truth = collective_name(min(later, key=lambda d: d.end_s).collective) if later else None
    correct = None if truth is None or probe["timed_out"] else probe["answer"] == truth
    return probe | {"truth": truth, "correct": correct}
