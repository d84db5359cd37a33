"""Calibration of the shared world to the study's published quantities.

Two parameters are fitted, both shared by M1, M2 and M3, each to one figure
the study publishes:

- `sensing_radius_m` (discovery "spatial"): so that the time until a
  collective's *first* explorer encounters a site at distance d matches the
  study's fitted discovery rate, 1/g(d) = 40, 89, 167 s at 150, 250, 350 m.
  The walk and the stop/resume-exploring rates are the engine's own
  (`movement.move`, `rules.rate_transitions`); nothing is adopted, so one run
  measures every radius of a grid at once.
- `message_rate` (r_msg): so that M1's mean decision time in the
  simulation-only experiment is the study's 2.46 min. Decision time falls
  with r_msg; the fit is a secant search on log(time) against log(r_msg).

`hcss simulate calibrate` runs both and prints the fit, so whoever changes dt,
the walk or the world can recalibrate, then copy the values into params.py.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from hcss.experiments import experiment as exp
from hcss.simulation import movement, rules
from hcss.simulation import states as S
from hcss.simulation.params import Params
from hcss.simulation.scenario import one_collective

STUDY_M1_DECISION_MIN = 2.46  # the study's published mean decision time of M1, minutes
RADIUS_GRID_M = np.round(np.arange(1.0, 30.01, 0.25), 2)


@dataclass(frozen=True)
class RadiusFit:
    """First-encounter times per distance for each radius of the grid, and the chosen radius."""

    distances_m: tuple[float, ...]
    target_s: tuple[float, ...]  # 1/g(d)
    radius_m: float
    mean_first_s: tuple[float, ...]  # at the chosen radius
    sem_first_s: tuple[float, ...]
    runs: int


def first_encounters(
    params: Params,
    distances_m: tuple[float, ...],
    radii_m: np.ndarray,
    seed: int,
    limit_s: float = 3600.0,
) -> np.ndarray:
    """(radii, distances) time until the collective's first explorer comes within each radius.

    Times not reached by `limit_s` are recorded as `limit_s` (censored; the
    limit is many times 1/g at every distance the study used).
    """
    from hcss.simulation.engine import Simulation

    layout = one_collective([(d, 1.0) for d in distances_m], seed, f"calibration-{seed}", 0.3)
    sim = Simulation(layout, "M1", params)
    w = sim.world
    first = np.full((radii_m.size, len(distances_m)), limit_s)
    pending = np.ones_like(first, dtype=bool)
    r2 = radii_m[:, None] ** 2
    while pending.any() and w.time < limit_s:
        _, at_hub = movement.move(w, params)
        rules.reach_hub(w, at_hub)
        rules.rate_transitions(w, params, "M1")
        w.step_count += 1
        w.time = w.step_count * params.dt_s
        explorers = np.flatnonzero((w.leg == S.EXPLORING) & (w.state == S.U_L))
        if explorers.size == 0:
            continue
        delta = w.pos[explorers, None, :] - w.target_pos[None, :, :]
        nearest2 = np.min(delta[..., 0] ** 2 + delta[..., 1] ** 2, axis=0)  # per target
        hit = pending & (nearest2[None, :] <= r2)
        first[hit] = w.time
        pending &= ~hit
    return first


def fit_sensing_radius(
    params: Params,
    runs: int = 40,
    seed: int = 1,
    progress: Callable[[], None] | None = None,
) -> RadiusFit:
    """The radius whose first-encounter times best match 1/g(d) (least squares in log time)."""
    distances = tuple(float(d) for d in params.target_distances_m)
    target = 1.0 / np.asarray(params.discovery_rate(np.array(distances)))
    samples = []
    for run in range(runs):
        samples.append(first_encounters(params, distances, RADIUS_GRID_M, seed * 10_000 + run))
        if progress is not None:
            progress()
    times = np.stack(samples)  # (runs, radii, distances)
    mean = times.mean(axis=0)
    error = np.sum((np.log(mean) - np.log(target)[None, :]) ** 2, axis=1)
    best = int(np.argmin(error))
    sem = times[:, best, :].std(axis=0, ddof=1) / math.sqrt(runs)
    return RadiusFit(
        distances_m=distances,
        target_s=tuple(float(t) for t in target),
        radius_m=float(RADIUS_GRID_M[best]),
        mean_first_s=tuple(float(t) for t in mean[best]),
        sem_first_s=tuple(float(s) for s in sem),
        runs=runs,
    )


@dataclass(frozen=True)
class RateFit:
    """The secant search for r_msg: every rate tried and M1's mean decision time there."""

    tried: tuple[tuple[float, float, float], ...]  # (rate, mean minutes, standard error)
    rate: float
    target_min: float = STUDY_M1_DECISION_MIN


def m1_decision_time(
    params: Params, scenarios: int, runs: int, workers: int, seed: int = 20_150_000
) -> tuple[float, float]:
    """M1's mean decision time (minutes) and its standard error over trials, no operator."""
    jobs = exp.jobs_for(exp.experiment_scenarios(scenarios, seed, params), ["M1"], runs)
    rows = exp.run_jobs(jobs, workers, params=params)
    minutes = np.array([r["decision_time_s"] / 60.0 for r in rows])
    per_trial: dict[str, list[float]] = {}
    for r in rows:
        per_trial.setdefault(r["trial_id"], []).append(r["decision_time_s"] / 60.0)
    trial_means = np.array([np.mean(v) for v in per_trial.values()])
    sem = float(trial_means.std(ddof=1) / math.sqrt(trial_means.size))
    return float(minutes.mean()), sem


def fit_message_rate(
    params: Params,
    scenarios: int = 28,
    runs: int = 2,
    workers: int = 2,
    iterations: int = 4,
    target_min: float = STUDY_M1_DECISION_MIN,
    report: Callable[[float, float, float], None] | None = None,
) -> RateFit:
    """Secant search on log(time) = a + b·log(r_msg) for M1's published mean decision time."""
    tried: list[tuple[float, float, float]] = []

    def measure(rate: float) -> float:
        mean, sem = m1_decision_time(
            params.with_changes(message_rate=rate), scenarios, runs, workers
        )
        tried.append((rate, mean, sem))
        if report is not None:
            report(rate, mean, sem)
        return mean

    r0, r1 = params.message_rate, params.message_rate * 1.5
    t0, t1 = measure(r0), measure(r1)
    for _ in range(max(0, iterations - 2)):
        slope = (math.log(t1) - math.log(t0)) / (math.log(r1) - math.log(r0))
        if not math.isfinite(slope) or slope >= -1e-3:
            slope = -1.0  # decision time must fall with the message rate; assume 1/r
        step = (math.log(target_min) - math.log(t1)) / slope
        r2 = float(np.clip(math.exp(math.log(r1) + step), r1 / 4, r1 * 4))
        r0, t0, r1, t1 = r1, t1, r2, measure(r2)
    return RateFit(
        tried=tuple(tried), rate=interpolate_rate(tried, target_min), target_min=target_min
    )


def interpolate_rate(tried: list[tuple[float, float, float]], target_min: float) -> float:
    """The rate where the line through the two measurements nearest the target meets it.

    log(time) against log(r_msg) through the two (rate, minutes) points whose
    times are closest to the target; the nearest point alone if the line is
    flat or rising (noise), so the fit never leaves the measured region by much.
    """
    nearest = sorted(tried, key=lambda row: abs(math.log(row[1] / target_min)))
    (ra, ta, _), *rest = nearest
    if not rest:
        return round(ra, 3)
    rb, tb, _ = rest[0]
    if ra == rb or math.log(tb / ta) / math.log(rb / ra) >= 0:
        return round(ra, 3)
    slope = math.log(tb / ta) / math.log(rb / ra)
    rate = math.exp(math.log(ra) + math.log(target_min / ta) / slope)
    low, high = min(r for r, _, _ in tried), max(r for r, _, _ in tried)
    return round(float(np.clip(rate, low / 2, high * 2)), 3)


def radius_table(fit: RadiusFit) -> str:
    lines = [
        "| distance (m) | study 1/g(d) (s) | first explorer (s), mean ± SE |",
        "|---|---|---|",
    ]
    for d, t, m, s in zip(
        fit.distances_m, fit.target_s, fit.mean_first_s, fit.sem_first_s, strict=True
    ):
        lines.append(f"| {d:.0f} | {t:.0f} | {m:.0f} ± {s:.0f} |")
    return "\n".join(lines)


def rate_table(fit: RateFit) -> str:
    lines = ["| r_msg (1/s) | M1 mean decision time (min) ± SE |", "|---|---|"]
    for rate, mean, sem in fit.tried:
        lines.append(f"| {rate:.3f} | {mean:.2f} ± {sem:.2f} |")
    return "\n".join(lines)
