"""The structural question of issue 28, as a map over the paper's readings.

Can any reading of the paper's rates give M1 little and M2 much value
discrimination on easy decisions, at the study's times (M1 70.5% at 2.18 min,
M2 76.7% at 4.17 min on easy decisions; M2 64.0% at 5.77 min on difficult
ones)? Both models answer on the same simple layouts (one collective at the
origin, its own four sites, one decision, no operator): the mean-field
equations (`meanfield.solve_meanfield`) and the agent model
(`crosscheck.agent_decision`), with the same params in every cell and for
both M1 and M2 (only M2 runs its mechanisms).

The grid, over what the paper states loosely or fits rather than states:

- how μ, ξ's discovery is read: **per agent** (every explorer finds a site at
  g(d)); **per collective** (the collective's first explorer finds it after
  1/g(d): the agent model's spatial discovery at the calibrated sensing
  radius; in the equations g(d) shared by the expected explorers); **per
  returning discoverer** (the fitted data were times until a discoverer is
  back in the hub, so an explorer finds a site at γ(d) = 1/(1/g(d) − d/speed),
  μ and ξ refitted to γ over 150–500 m and used wherever g is, F_D's wait too);
- d_max of F_D and F_R (the sites' 352 m up to the search space's 500 m);
- a scale on F_D's wait (the unit of d inside g);
- M2's mechanisms: all three, F_R removed, M_i removed;
- (issue 39) which uses of an F_I agent's messages carry M_i (a '+'-joined set
  of queue, recruitment, inhibition: `Params.m2_modulation_uses`), whether M1's
  queue messages carry it too (`m1_queue_modulation`, both models' cells), and
  d_min from the search space or the layout's nearest site (`m2_d_min`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hcss.experiments.crosscheck import agent_decision
from hcss.experiments.meanfield import Site, solve_meanfield
from hcss.simulation.params import M1_QUEUE_MODULATION, M2_D_MIN, M2_MECHANISMS, Params
from hcss.tidy_csv import write_rows

# Best nearest (easy under every label), best in the middle ring (easy under the loose
# label "best not the furthest", difficult under "best nearest"), best furthest (difficult).
LAYOUTS: dict[str, list[Site]] = {
    "best_nearest": [Site(150.0, 1.0), Site(250.0, 0.9), Site(350.0, 0.8), Site(250.0, 0.7)],
    "best_middle": [Site(250.0, 1.0), Site(150.0, 0.9), Site(350.0, 0.8), Site(350.0, 0.7)],
    "best_furthest": [Site(350.0, 1.0), Site(150.0, 0.9), Site(250.0, 0.8), Site(150.0, 0.7)],
}
DISCOVERY = ("per_agent", "per_collective", "returning_discoverer")
D_MAX_M = (352.0, 430.0, 500.0)
WAIT_SCALES = (0.05, 0.15, 1.0)
MECHANISMS: dict[str, tuple[str, ...]] = {
    "all": M2_MECHANISMS,
    "no_F_R": tuple(m for m in M2_MECHANISMS if m != "reassessment_delay"),
    "no_M_i": tuple(m for m in M2_MECHANISMS if m != "modulation"),
}
ALL_USES = "queue+recruitment+inhibition"
COLUMNS = (
    "discovery",
    "m1_queue",
    "d_min",
    "d_max_m",
    "wait_scale",
    "mechanisms",
    "uses",
    "model",
    "layout",
    "method",
    "p_best",
    "time_min",
    "undecided",
    "runs",
)

# The study's easy and difficult cells (spec §10) and the bands of the calibration.
STUDY = {
    ("M1", "easy"): (70.49, 2.18),
    ("M1", "difficult"): (6.8, 3.2),
    ("M2", "easy"): (76.7, 4.17),
    ("M2", "difficult"): (64.04, 5.77),
}
RATE_BAND, TIME_BAND = 10.0, 1.0


def returning_discoverer_fit(params: Params) -> tuple[float, float]:
    """μ, ξ of the per-agent rate γ(d) = 1/(1/g(d) − d/speed), fitted like the paper's
    g (log-linear least squares of d·γ(d) on d, d in 100 m) over 150–500 m."""
    d = np.linspace(150.0, 500.0, 36)
    gamma = 1.0 / (1.0 / np.asarray(params.discovery_rate(d)) - d / params.speed_mps)
    x = d / params.discovery_unit_m
    xi, log_mu = np.polyfit(x, np.log(gamma * x), 1)
    return float(math.exp(log_mu)), float(xi)


def expected_explorers(params: Params) -> float:
    """Agents exploring at the rates' balance, P_L/(P_L + P_U^I)·N (180 of 200)."""
    share = params.resume_rate / (params.resume_rate + params.stop_exploring_rate)
    return share * params.n_agents


def reading_params(base: Params, discovery: str) -> tuple[Params, float]:
    """The params of one discovery reading, and the equations' discovery scale."""
    if discovery == "per_agent":
        return base.with_changes(discovery="per_agent"), 1.0
    if discovery == "per_collective":
        return base.with_changes(discovery="spatial"), 1.0 / expected_explorers(base)
    if discovery == "returning_discoverer":
        mu, xi = returning_discoverer_fit(base)
        return base.with_changes(discovery="per_agent", discovery_mu=mu, discovery_xi=xi), 1.0
    raise ValueError(f"discovery must be one of {', '.join(DISCOVERY)}, not {discovery!r}")


@dataclass(frozen=True)
class Cell:
    """One point of the grid: a discovery reading and, for M2, its delays and mechanisms."""

    discovery: str
    model: str
    d_max_m: float | None = None  # None for M1, which has no delays
    wait_scale: float | None = None
    mechanisms: str | None = None
    uses: str | None = None  # M2: the uses carrying M_i, '+'-joined
    m1_queue: str = "unmodulated"  # both models (shared): M1's queue messages × M_i or not
    d_min: str = "search_space"  # both models (shared): d_min of M_i

    def params(self, base: Params) -> tuple[Params, float]:
        params, scale = reading_params(base, self.discovery)
        params = params.with_changes(m1_queue_modulation=self.m1_queue, m2_d_min=self.d_min)
        if self.model == "M2":
            if self.d_max_m is None or self.wait_scale is None or self.mechanisms is None:
                raise ValueError("an M2 cell needs d_max_m, wait_scale and mechanisms")
            params = params.with_changes(
                m2_distance_bounds="fitted",
                fitted_d_max_m=self.d_max_m,
                m2_discovery_wait_scale=self.wait_scale,
                m2_mechanisms=MECHANISMS[self.mechanisms],
                m2_modulation_uses=tuple((self.uses or ALL_USES).split("+")),
            )
        return params, scale


def grid(
    discovery: Iterable[str] = DISCOVERY,
    d_max_m: Iterable[float] = D_MAX_M,
    wait_scales: Iterable[float] = WAIT_SCALES,
    mechanisms: Iterable[str] = tuple(MECHANISMS),
    uses: Iterable[str] = (ALL_USES,),
    m1_queue: Iterable[str] = ("unmodulated",),
    d_min: Iterable[str] = ("search_space",),
) -> Iterator[Cell]:
    """M1 once per discovery reading and shared reading (M1 runs none of M2's values), then
    M2's cells."""
    d_max_m, wait_scales, mechanisms = tuple(d_max_m), tuple(wait_scales), tuple(mechanisms)
    uses, m1_queue, d_min = tuple(uses), tuple(m1_queue), tuple(d_min)
    for name in m1_queue:
        if name not in M1_QUEUE_MODULATION:
            raise ValueError(f"m1_queue must be among {', '.join(M1_QUEUE_MODULATION)}")
    for name in d_min:
        if name not in M2_D_MIN:
            raise ValueError(f"d_min must be among {', '.join(M2_D_MIN)}")
    for reading in discovery:
        for queue in m1_queue:
            for low in d_min:
                yield Cell(reading, "M1", m1_queue=queue, d_min=low)
                for d_max in d_max_m:
                    for scale in wait_scales:
                        for kept in mechanisms:
                            for used in uses:
                                yield Cell(reading, "M2", d_max, scale, kept, used, queue, low)


def measure(cell: Cell, base: Params, runs: int, seed: int = 7) -> list[dict[str, Any]]:
    """The cell on every layout: the equations' and the agent model's P(best) and time."""
    params, scale = cell.params(base)
    rows = []
    key = {
        "discovery": cell.discovery,
        "m1_queue": cell.m1_queue,
        "d_min": cell.d_min,
        "d_max_m": cell.d_max_m,
        "wait_scale": cell.wait_scale,
        "mechanisms": cell.mechanisms,
        "uses": cell.uses if cell.model == "M2" else None,
        "model": cell.model,
    }
    for layout, sites in LAYOUTS.items():
        best = int(np.argmax([s.value for s in sites]))
        ode = solve_meanfield(sites, cell.model, params, discovery_scale=scale)
        rows.append(
            key
            | {
                "layout": layout,
                "method": "mean-field",
                "p_best": ode.win_probability[best],
                "time_min": ode.decision_s / 60.0 if math.isfinite(ode.decision_s) else None,
                "undecided": ode.undecided,
                "runs": None,
            }
        )
        agent = [agent_decision(sites, cell.model, params, seed * 1000 + i) for i in range(runs)]
        decided = [t for chosen, t in agent if chosen >= 0]
        rows.append(
            key
            | {
                "layout": layout,
                "method": "agent",
                "p_best": float(np.mean([chosen == best for chosen, _ in agent])),
                "time_min": float(np.mean(decided)) / 60.0 if decided else None,
                "undecided": 1.0 - len(decided) / runs,
                "runs": runs,
            }
        )
    return rows


def run_map(
    base: Params,
    runs: int,
    cells: Iterable[Cell] | None = None,
    on_cell: Callable[[], None] | None = None,
) -> list[dict[str, Any]]:
    """Every cell of the grid, measured; rows in the columns of `COLUMNS`."""
    rows: list[dict[str, Any]] = []
    for cell in grid() if cells is None else cells:
        rows += measure(cell, base, runs)
        if on_cell is not None:
            on_cell()
    return rows


def write_map(rows: list[dict[str, Any]], path: Path) -> None:
    write_rows(path, COLUMNS, rows)


def _easy_reaches(m2: dict[str, dict[str, Any]]) -> bool:
    """M2 on the best-nearest layout within band of the study's easy cell (rate and time),
    and on the best-furthest layout within band of its difficult rate."""
    near, far = m2["best_nearest"], m2["best_furthest"]
    easy_rate, easy_time = STUDY[("M2", "easy")]
    difficult_rate, _ = STUDY[("M2", "difficult")]
    return (
        100.0 * near["p_best"] >= easy_rate - RATE_BAND
        and near["time_min"] is not None
        and abs(near["time_min"] - easy_time) <= TIME_BAND
        and 100.0 * far["p_best"] >= difficult_rate - RATE_BAND
    )


def _fmt(row: dict[str, Any]) -> str:
    time = "–" if row["time_min"] is None else f"{row['time_min']:.1f}"
    return f"{row['p_best']:.2f}, {time}"


def summary_markdown(rows: list[dict[str, Any]]) -> str:
    """P(best), time (min) per layout, both methods, one line per cell; and which cells
    reach the study's M2 easy cell at its time with its difficult rate."""
    by_cell: dict[tuple[Any, ...], dict[str, dict[str, dict[str, Any]]]] = {}
    for row in rows:
        key = (
            row["discovery"],
            row.get("m1_queue", "unmodulated"),
            row.get("d_min", "search_space"),
            row["model"],
            row["d_max_m"],
            row["wait_scale"],
            row["mechanisms"],
            row.get("uses"),
        )
        by_cell.setdefault(key, {}).setdefault(row["method"], {})[row["layout"]] = row
    lines = [
        "P(best), decision time (min) per layout: mean-field (MF) and agent model. "
        "Reaches: M2 within band of the study's easy cell (≥ 66.7% at 3.17–5.17 min) on the "
        "best-nearest layout and ≥ 54.0% on the best-furthest one, in that method.",
        "",
        "| discovery | M1 queue | d_min | model | d_max | F_D wait | mechanisms | M_i on | "
        + " | ".join(f"{layout} {m}" for layout in LAYOUTS for m in ("MF", "agent"))
        + " | reaches (MF / agent) |",
        "|---|---|---|---|---|---|---|---|" + "---|" * (2 * len(LAYOUTS)) + "---|",
    ]
    reached = {"mean-field": 0, "agent": 0}
    m2_cells = 0
    for (discovery, queue, low, model, d_max, scale, kept, used), methods in by_cell.items():
        cells = []
        for layout in LAYOUTS:
            cells += [
                _fmt(methods[m][layout]) if m in methods else "–" for m in ("mean-field", "agent")
            ]
        verdict = "–"
        if model == "M2":
            m2_cells += 1
            flags = []
            for method in ("mean-field", "agent"):
                ok = method in methods and _easy_reaches(methods[method])
                reached[method] += ok
                flags.append("yes" if ok else "no")
            verdict = " / ".join(flags)
        lines.append(
            f"| {discovery} | {queue} | {low} | {model} | "
            f"{'–' if d_max is None else f'{d_max:.0f} m'} | "
            f"{'–' if scale is None else f'{scale:g}'} | {kept or '–'} | {used or '–'} | "
            + " | ".join(cells)
            + f" | {verdict} |"
        )
    lines += [
        "",
        f"M2 cells reaching the study's easy cell: {reached['mean-field']} of {m2_cells} "
        f"(mean-field), {reached['agent']} of {m2_cells} (agent model).",
    ]
    return "\n".join(lines)
