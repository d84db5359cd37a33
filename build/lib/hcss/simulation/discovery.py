"""Per-agent discovery: the paper's P_γ = v·g(d) read as a rate per exploring agent.

The study fitted g(d) = μ·e^(ξ·d)/d to how fast sites at distance d are
discovered and defines the discovery transition as P_γ = v·g(d). Read per
agent, every exploring agent finds each eligible site in range at rate g(d_i)
and adopts it with probability v̂ (`params.discovery == "per_agent"`). The
agent's flights stay spatial: it keeps walking while it explores and, on
adopting a site, flies home from where it is.

The rule itself is the discovery part of the compiled `rules.agent_rules_kernel`
(both readings); the other reading ("spatial", the default) leaves discovery to the encounter
within the sensing radius, whose radius `hcss simulate calibrate` fits so that
the collective's first explorer finds a site after 1/g(d).
"""

from __future__ import annotations

import numpy as np

from hcss.simulation.params import Params
from hcss.simulation.rules import discoverable
from hcss.simulation.world import World


def site_rates(world: World, params: Params) -> np.ndarray:
    """(C, T) per-agent discovery rate g(d) of each eligible site, 0 for the others.

    `world.site_rate` is g(d) with d floored at the hub radius (`rules.site_rate`).
    """
    return np.where(discoverable(world, params), world.site_rate, 0.0)
