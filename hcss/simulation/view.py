"""What the Collective Interface shows (spec §9): a typed `Display`, and its JSON.

`Simulation.display()` is what an operator may know, as read-only numpy
arrays: the scripted operators (`operators.py`), the platform's probes and
its action checks read it. `Display.to_json()` is the same thing as plain
JSON-able values, for the browser (`Simulation.view()`), and
`Display.from_json` reads it back (the bots, which see only the stream). Neither carries the
truth (true target values, the best target): that comes only from
`Simulation.truth()`, so nothing shown can leak it.

Collective state counts are hub estimates: each agent's last state reported
at the hub, so an agent away exploring still counts as what it was when it
left. Target values shown are the mean of the estimates reported at hubs.
Targets are named by their public (1-based) ids; collectives by 0-based index.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import TYPE_CHECKING, Any

import numpy as np

from hcss.simulation import decisions as dec
from hcss.simulation import states as S
from hcss.simulation.ids import target_id, target_ids, target_index
from hcss.simulation.messages import collective_name
from hcss.simulation.requests import RequestState

if TYPE_CHECKING:
    from hcss.simulation.engine import Simulation


@dataclass(frozen=True, eq=False)  # arrays: compare fields, or the JSON
class Display:
    """The interface at one moment. C collectives; V visible targets, in id order.

    Per collective: `hub` (C, 2) metres, `state_counts` (C, 4) agents per
    quadrant of `states.QUADRANTS` (U, F, C, X), `executing` (C,), and the
    move under way: `move_target` (C,) id or 0 for none, `move_progress` (C,)
    0-1, `move_position` (C, 2) where the travelling box is drawn.
    Per visible target: `target_ids` (V,), `position` (V, 2), `value` (V,)
    the reported mean, `reports` (V,), `drawn` (V,) (value colour shown),
    `outlined` (V,) (some collective's support above `Params.outline_support`),
    `outline_executing` (V,); `support` (C, V) the fraction of each collective
    favouring each target, `in_range` (C, V).
    """

    time: float
    step: int
    section: int  # 1-based
    n_sections: int
    decisions_in_section: int
    finished: bool
    n_agents: int  # per collective
    range_m: float
    hub: np.ndarray
    state_counts: np.ndarray
    executing: np.ndarray
    move_target: np.ndarray
    move_progress: np.ndarray
    move_position: np.ndarray
    target_ids: np.ndarray
    position: np.ndarray
    value: np.ndarray
    reports: np.ndarray
    drawn: np.ndarray
    outlined: np.ndarray
    outline_executing: np.ndarray
    support: np.ndarray
    in_range: np.ndarray
    requests: tuple[RequestState, ...]

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, np.ndarray):
                value.setflags(write=False)  # a display is a reading, never a handle on the state

    @property
    def n_collectives(self) -> int:
        return int(self.hub.shape[0])

    def column(self, target: int) -> int | None:
        """The column of the visible target with this id in the per-target arrays, or None."""
        found = np.flatnonzero(self.target_ids == target)
        return int(found[0]) if found.size else None

    def to_json(self) -> dict[str, Any]:
        """The browser's view: JSON-able values (the contract in docs/simulation-api.md)."""
        n = self.n_agents
        counts = self.state_counts.tolist()
        hubs, executing = self.hub.tolist(), self.executing.tolist()
        moves = zip(
            self.move_target.tolist(),
            self.move_progress.tolist(),
            self.move_position.tolist(),
            strict=True,
        )
        collectives = [
            {
                "index": c,
                "name": collective_name(c),
                "hub": hubs[c],
                "range_m": self.range_m,
                "fractions": {q: counts[c][i] / n for i, q in enumerate(S.QUADRANTS)},
                "counts": dict(zip(S.QUADRANTS, counts[c], strict=True)),
                "executing": executing[c],
                "move": {"target": t, "progress": progress, "position": position} if t else None,
            }
            for c, (t, progress, position) in enumerate(moves)
        ]
        ids, positions, values = (
            self.target_ids.tolist(),
            self.position.tolist(),
            self.value.tolist(),
        )
        reports, drawn = self.reports.tolist(), self.drawn.tolist()
        outlined, outline_executing = self.outlined.tolist(), self.outline_executing.tolist()
        support = self.support.T.tolist()
        targets = [
            {
                "id": ids[v],
                "position": positions[v],
                "value": values[v],
                "reports": reports[v],
                "drawn": drawn[v],
                "support": support[v],
                "max_support": max(support[v]),
                "outline_support": outlined[v],
                "outline_executing": outline_executing[v],
                "in_range_of": np.flatnonzero(self.in_range[:, v]).tolist(),
            }
            for v in range(len(ids))
        ]
        return {
            "time": self.time,
            "step": self.step,
            "section": self.section,
            "n_sections": self.n_sections,
            "decisions_in_section": self.decisions_in_section,
            "finished": self.finished,
            "collectives": collectives,
            "targets": targets,
            "requests": [asdict(r) for r in self.requests],
        }

    @classmethod
    def from_json(cls, view: dict[str, Any]) -> Display:
        """The display back from its JSON (what a client of the stream gets), e.g. for a bot."""
        collectives, targets = view["collectives"], view["targets"]
        n_c = len(collectives)
        counts = np.array(
            [[c["counts"][q] for q in S.QUADRANTS] for c in collectives], dtype=np.int64
        ).reshape(n_c, len(S.QUADRANTS))
        moves = [
            c["move"] or {"target": 0, "progress": 0.0, "position": [0.0, 0.0]} for c in collectives
        ]
        return cls(
            time=view["time"],
            step=view["step"],
            section=view["section"],
            n_sections=view["n_sections"],
            decisions_in_section=view["decisions_in_section"],
            finished=view["finished"],
            n_agents=int(counts[0].sum()) if n_c else 0,
            range_m=collectives[0]["range_m"] if n_c else 0.0,
            hub=np.array([c["hub"] for c in collectives], dtype=float).reshape(n_c, 2),
            state_counts=counts,
            executing=np.array([c["executing"] for c in collectives], dtype=bool),
            move_target=np.array([m["target"] for m in moves], dtype=np.int64),
            move_progress=np.array([m["progress"] for m in moves], dtype=float),
            move_position=np.array([m["position"] for m in moves], dtype=float).reshape(n_c, 2),
            target_ids=np.array([t["id"] for t in targets], dtype=np.int64),
            position=np.array([t["position"] for t in targets], dtype=float).reshape(-1, 2),
            value=np.array([t["value"] for t in targets], dtype=float),
            reports=np.array([t["reports"] for t in targets], dtype=np.int64),
            drawn=np.array([t["drawn"] for t in targets], dtype=bool),
            outlined=np.array([t["outline_support"] for t in targets], dtype=bool),
            outline_executing=np.array([t["outline_executing"] for t in targets], dtype=bool),
            support=np.array([t["support"] for t in targets], dtype=float).reshape(-1, n_c).T,
            in_range=np.array(
                [[c in t["in_range_of"] for t in targets] for c in range(n_c)], dtype=bool
            ).reshape(n_c, len(targets)),
            requests=tuple(RequestState(**r) for r in view["requests"]),
        )


@dataclass(frozen=True, eq=False)
class Truth:
    """What the operator cannot see, to score answers against (`Simulation.truth()`).

    `values` (T,) every target's true value in id order (`value_of(id)`);
    `best_target` (C,) the id of each collective's best available target, 0 for none.
    """

    values: np.ndarray
    best_target: np.ndarray

    def __post_init__(self) -> None:
        self.values.setflags(write=False)
        self.best_target.setflags(write=False)

    def value_of(self, target: int) -> float:
        """The true value of the target with this id."""
        return float(self.values[target_index(target)])

    def best_for(self, collective: int) -> int | None:
        """The id of the collective's best available target; None when none is left."""
        best = int(self.best_target[collective])
        return best or None


def display_of(sim: Simulation) -> Display:
    """The simulation's display now (`Simulation.display`)."""
    w, p = sim.world, sim.params
    n_c = w.n_collectives
    quadrant_counts = np.zeros((n_c, len(S.QUADRANTS)), dtype=np.int64)
    np.add.at(quadrant_counts, (w.collective, w.reported_quadrant), 1)
    visible = np.flatnonzero(w.active & (w.report_count >= p.visible_reports))
    support = w.support()[:, visible]
    reports = w.report_count[visible].astype(np.int64)
    executing_to = w.executing[w.executing >= 0]
    move_target = np.zeros(n_c, dtype=np.int64)
    move_progress = np.zeros(n_c)
    move_position = np.zeros((n_c, 2))
    for c in np.flatnonzero(w.executing >= 0).tolist():
        t = int(w.executing[c])
        move_target[c] = target_id(t)
        move_progress[c], move_position[c] = _move(sim, c, t)
    return Display(
        time=w.time,
        step=w.step_count,
        section=w.section + 1,
        n_sections=len(sim.scenario.sections),
        decisions_in_section=w.decisions_in_section,
        finished=w.finished,
        n_agents=p.n_agents,
        range_m=p.exploration_range_m,
        hub=np.array(w.hub, dtype=float),
        state_counts=quadrant_counts,
        executing=w.executing >= 0,
        move_target=move_target,
        move_progress=move_progress,
        move_position=move_position,
        target_ids=target_ids(visible),
        position=np.array(w.target_pos[visible], dtype=float),
        value=w.report_sum[visible] / reports,
        reports=reports,
        drawn=reports >= p.drawn_reports,
        outlined=support.max(axis=0, initial=0.0) > p.outline_support,
        outline_executing=np.isin(visible, executing_to),
        support=support,
        in_range=w.hub_distance[:, visible] <= p.exploration_range_m,
        requests=tuple(r.state() for r in sim.requests),
    )


def truth_of(sim: Simulation) -> Truth:
    """The simulation's truth now (`Simulation.truth`)."""
    w = sim.world
    best = [dec.best_available(w, c, sim.params) for c in range(w.n_collectives)]
    return Truth(
        values=np.array(w.target_value, dtype=float),
        best_target=np.array([0 if b < 0 else target_id(b) for b in best], dtype=np.int64),
    )


def _move(sim: Simulation, c: int, t: int) -> tuple[float, np.ndarray]:
    """A move under way: its progress 0–1 and where to draw the travelling box."""
    w = sim.world
    start, goal = w.hub[c], w.target_pos[t]
    length = float(np.hypot(*(goal - start))) or 1.0
    movers = (w.collective == c) & ((w.state == S.X) | (w.state == S.D))
    if movers.any():
        remaining = np.hypot(*(goal - w.pos[movers]).T)
        progress = float(np.clip(1.0 - np.mean(np.minimum(remaining, length)) / length, 0.0, 1.0))
    else:
        progress = 0.0
    return progress, start + progress * (goal - start)
