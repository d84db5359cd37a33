"""Per-agent discovery: the paper's P_γ = v·g(d) read as a rate per exploring agent.

The study fitted g(d) = μ·e^(ξ·d)/d to how fast sites at distance d are
discovered and defines the discovery transition as P_γ = v·g(d). Read per
agent, every exploring agent finds each eligible site in range at rate g(d_i)
and adopts it with probability v̂ (`params.discovery == "per_agent"`). The
agent's flights stay spatial: it keeps walking while it explores and, on
adopting a site, flies home from where it is.

The other reading ("spatial", the default engine rule in `rules.discovery`)
leaves discovery to the encounter within the sensing radius, whose radius
`hcss simulate calibrate` fits so that the collective's first explorer finds a
site after 1/g(d).
"""

from __future__ import annotations

import numpy as np

from hcss.simulation import states as S
from hcss.simulation.params import Params
from hcss.simulation.rules import adopt_on_discovery, discoverable
from hcss.simulation.world import World


def site_rates(world: World, params: Params) -> np.ndarray:
    """(C, T) per-agent discovery rate g(d) of each eligible site, 0 for the others.

    Distances are floored at the hub radius: a site can be no nearer than the
    edge of the hub area, and g(d) diverges at d = 0.
    """
    ok = discoverable(world, params)
    distance = np.maximum(world.hub_distance, params.hub_radius_m)
    return np.where(ok, params.discovery_rate(distance), 0.0)


def discover_per_agent(world: World, params: Params, rng: np.random.Generator, model: str) -> None:
    """U_L → F_L(i) at rate g(d_i) per explorer and site, adopted with probability v̂.

    An explorer finds some site within one step with probability
    1 − exp(−Σ_i g(d_i)·dt); which one is drawn in proportion to the rates.
    """
    explorers = np.flatnonzero((world.leg == S.EXPLORING) & (world.state == S.U_L))
    if explorers.size == 0:
        return
    rates = site_rates(world, params)
    total = rates.sum(axis=1)
    if not total.any():
        return
    col = world.collective[explorers]
    found = rng.random(explorers.size) < -np.expm1(-total[col] * params.dt_s)
    agents = explorers[found]
    if agents.size == 0:
        return
    cumulative = np.cumsum(rates[world.collective[agents]], axis=1)
    pick = rng.random(agents.size) * cumulative[:, -1]
    targets = (cumulative <= pick[:, None]).sum(axis=1)
    adopt_on_discovery(world, agents, targets, params, rng, model)
