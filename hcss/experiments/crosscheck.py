"""Each model checks the other: mean-field predictions beside the agent model's decisions.

Simple layouts only: one collective at the origin with its own four sites
(values 0.7–1.0 at the study's distances), one decision, no operator. The
agent model runs with the same parameters as the mean-field model; discovery
per agent (the paper's P_γ), since that is the mean-field model's discovery.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hcss.experiments.meanfield import Site, solve_meanfield
from hcss.experiments.meanfield_chain import run_chain
from hcss.simulation.params import Params
from hcss.simulation.scenario import Scenario, one_collective

# The study's layouts: the best site near (easy) or farthest (difficult).
LAYOUTS: dict[str, list[Site]] = {
    "easy": [Site(150.0, 1.0), Site(250.0, 0.9), Site(350.0, 0.8), Site(250.0, 0.7)],
    "difficult": [Site(350.0, 1.0), Site(150.0, 0.9), Site(250.0, 0.8), Site(150.0, 0.7)],
}


def layout_scenario(sites: list[Site], seed: int) -> Scenario:
    """One collective at the origin, its sites at the given distances, spread in bearing."""
    sites_ = [(s.distance_m, s.value) for s in sites]
    return one_collective(sites_, seed, f"layout-{seed}", bearing_offset_rad=0.4)


def agent_decision(sites: list[Site], model: str, params: Params, seed: int) -> tuple[int, float]:
    """The agent model's first decision on a layout: (site index or -1, decision time in s)."""
    from hcss.simulation.engine import Simulation

    p = params.with_changes(decisions_per_section=1)
    sim = Simulation(layout_scenario(sites, seed), model, p)
    sim.run_until_finished()
    record = sim.decisions[0]
    chosen = -1 if record.chosen_target is None else record.chosen_target - 1
    return chosen, record.decision_time_s


@dataclass(frozen=True)
class Comparison:
    """Best-site share and mean decision time of each reading on one layout."""

    layout: str
    model: str
    ode_best: float  # P(first quorum for the best site), ODE
    ode_time_s: float
    chain_best: float
    chain_time_s: float
    chain_time_se: float
    agent_best: float
    agent_time_s: float
    agent_time_se: float
    runs: int


def _mean_se(values: list[float]) -> tuple[float, float]:
    a = np.asarray(values, dtype=float)
    se = float(a.std(ddof=1) / math.sqrt(a.size)) if a.size > 1 else math.nan
    return float(a.mean()), se


def compare(layout: str, model: str, params: Params, runs: int, seed: int = 7) -> Comparison:
    sites = LAYOUTS[layout]
    best = int(np.argmax([s.value for s in sites]))
    ode = solve_meanfield(sites, model, params)
    rng = np.random.default_rng(seed)
    # The chain applies abandonment per visit only; under the "rate" reading its columns are NaN.
    chain_runs = runs if params.abandonment == "per_visit" else 0
    chain = [run_chain(sites, model, params, rng) for _ in range(chain_runs)]
    agent = [agent_decision(sites, model, params, seed * 1000 + i) for i in range(runs)]
    chain_time, chain_se = _mean_se([c.time_s for c in chain]) if chain else (math.nan, math.nan)
    agent_time, agent_se = _mean_se([t for _, t in agent])
    return Comparison(
        layout=layout,
        model=model,
        ode_best=ode.win_probability[best],
        ode_time_s=ode.decision_s,
        chain_best=float(np.mean([c.chosen == best for c in chain])) if chain else math.nan,
        chain_time_s=chain_time,
        chain_time_se=chain_se,
        agent_best=float(np.mean([c == best for c, _ in agent])),
        agent_time_s=agent_time,
        agent_time_se=agent_se,
        runs=runs,
    )


def comparison_table(rows: list[Comparison]) -> str:
    lines = [
        "| layout | model | ODE P(best) | chain P(best) | agent P(best) "
        "| ODE time (s) | chain time (s) ± SE | agent time (s) ± SE | runs |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {r.layout} | {r.model} | {r.ode_best:.2f} | {r.chain_best:.2f} | {r.agent_best:.2f} "
            f"| {r.ode_time_s:.0f} | {r.chain_time_s:.0f} ± {r.chain_time_se:.0f} "
            f"| {r.agent_time_s:.0f} ± {r.agent_time_se:.0f} | {r.runs} |"
        )
    return "\n".join(lines)
