"""What the Collective Interface shows (spec §9), as plain JSON-able values.

Collective state fractions are hub estimates: each agent's last state reported
at the hub, so an agent away exploring still counts as what it was when it
left. Target values shown are the mean of the estimates reported at hubs, and
the true value is included for analysis only; the interface must not show it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from hcss.simulation import states as S
from hcss.simulation.ids import target_id
from hcss.simulation.params import ROMAN

if TYPE_CHECKING:
    from hcss.simulation.engine import Simulation


def render_view(sim: Simulation) -> dict:
    w, p = sim.world, sim.params
    n = p.n_agents
    quadrant_counts = np.zeros((w.n_collectives, len(S.QUADRANTS)), dtype=np.int64)
    np.add.at(quadrant_counts, (w.collective, w.reported_quadrant), 1)
    support = w.support()
    collectives = []
    for c in range(w.n_collectives):
        counts = {q: int(quadrant_counts[c, i]) for i, q in enumerate(S.QUADRANTS)}
        collectives.append(
            {
                "index": c,
                "name": ROMAN[c],
                "hub": [float(w.hub[c, 0]), float(w.hub[c, 1])],
                "range_m": p.exploration_range_m,
                "fractions": {q: counts[q] / n for q in S.QUADRANTS},
                "counts": counts,
                "executing": bool(w.executing[c] >= 0),
                "move": _move(sim, c),
            }
        )
    targets = []
    executing_to = set(int(t) for t in w.executing if t >= 0)
    for t in np.flatnonzero(w.active & (w.report_count >= p.visible_reports)):
        count = int(w.report_count[t])
        per_collective = [float(s) for s in support[:, t]]
        targets.append(
            {
                "id": target_id(t),
                "position": [float(w.target_pos[t, 0]), float(w.target_pos[t, 1])],
                "value": float(w.report_sum[t] / count),
                "true_value": float(w.target_value[t]),
                "reports": count,
                "drawn": count >= p.drawn_reports,
                "support": per_collective,
                "max_support": max(per_collective),
                "outline_support": max(per_collective) > p.outline_support,
                "outline_executing": int(t) in executing_to,
                "in_range_of": [
                    c
                    for c in range(w.n_collectives)
                    if w.hub_distance[c, t] <= p.exploration_range_m
                ],
            }
        )
    return {
        "time": w.time,
        "step": w.step_count,
        "section": w.section + 1,
        "n_sections": len(sim.scenario.sections),
        "decisions_in_section": w.decisions_in_section,
        "finished": w.finished,
        "collectives": collectives,
        "targets": targets,
        "requests": [r.to_view() for r in sim.requests],
    }


def _move(sim: Simulation, c: int) -> dict | None:
    """A move under way: its target, progress 0–1 and where to draw the travelling box."""
    w = sim.world
    t = int(w.executing[c])
    if t < 0:
        return None
    start, goal = w.hub[c], w.target_pos[t]
    length = float(np.hypot(*(goal - start))) or 1.0
    movers = (w.collective == c) & ((w.state == S.X) | (w.state == S.D))
    if movers.any():
        remaining = np.hypot(*(goal - w.pos[movers]).T)
        progress = float(np.clip(1.0 - np.mean(np.minimum(remaining, length)) / length, 0.0, 1.0))
    else:
        progress = 0.0
    position = start + progress * (goal - start)
    return {
        "target": target_id(t),
        "progress": progress,
        "position": [float(position[0]), float(position[1])],
    }
