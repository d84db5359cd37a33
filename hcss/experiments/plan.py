"""`hcss plan`: the whole study in silico, and the power of its tests as a function of N.

1. A pool of synthetic participants (`synthetic_teams`), each through the study
   file's models, counterbalancing cells and trial length, and a pool of
   simulation-only scenarios (the simulation-only condition, `experiment`).
2. Their export (decisions with `source = synthetic` and `simulation`,
   participants, requests, observations, probes) analysed by the real
   `hcss analyze` pipeline (`hcss.analysis.report.run_analysis`): the predicted
   tables are its tables, nothing special-cased.
3. Power by resampling the analysis's own per-unit measures (`measures.csv`):
   N participants and N scenarios per replication (`hcss.analysis.power`),
   replications spread over a process pool or Dask, as sweeps are.
4. plan.html: the predicted per-decision tables beside the study's (§11),
   the power of each test with its Monte Carlo interval, power curves, the N
   that reaches 80% for each hypothesis, and every assumption.

The pool is simulated once; the replications only resample it.
"""

from __future__ import annotations

import base64
import html
import io
import json
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from hcss.analysis import power as pw
from hcss.experiments import experiment as exp
from hcss.experiments import study_claims, study_targets
from hcss.experiments import study_teams as teams
from hcss.experiments.synthetic_teams import (
    ORIGINAL_CELLS,
    participants,
    pooled,
    run_participants,
)
from hcss.experiments.synthetic_trials import TRIAL_S, TrialRows
from hcss.simulation.params import Params
from hcss.simulation.synthetic import Population
from hcss.tablespec import DECISIONS, EXPORT_TABLES
from hcss.tidy_csv import write_frame, write_rows

PLAN_BLOCK = 50_000_000  # participants' and their scenarios' seeds: apart from calibration's
SIMULATION_BLOCK = 60_000_000  # the simulation-only pool's scenarios
DEFAULT_NS = (12, 20, 28, 40, 60)


@dataclass(frozen=True)
class PlanSettings:
    """What a plan does; written into plan.html and plan.json."""

    study: str = "original"
    cells: tuple[tuple[tuple[str, str], ...], ...] = ORIGINAL_CELLS
    trial_s: float = TRIAL_S
    ns: tuple[int, ...] = DEFAULT_NS
    replications: int = 500
    pool_participants: int = 120
    pool_scenarios: int = 120
    scenario_runs: int = 3
    alpha: float = 0.05
    seed: int = 1
    population: str = "the operator's default traits (uncalibrated)"


@dataclass
class Plan:
    settings: PlanSettings
    points: list[pw.PowerPoint]
    measured: dict[tuple[str, str, str], teams.Measured]
    analysis_html: Path
    timings: dict[str, float] = field(default_factory=dict)
    # the simulation-only pool's success per decision (%) by (model, split): collectives alone
    alone: dict[tuple[str, str], float] = field(default_factory=dict)
    # per N, the chance a study of N bears out each of the study's words about its operators
    reproduced: dict[int, list[float]] = field(default_factory=dict)


def simulate_pool(
    settings: PlanSettings,
    population: Population,
    params: Params,
    workers: int,
    dask_address: str | None,
    progress: Callable[[], None] | None = None,
) -> tuple[TrialRows, list[dict[str, Any]], list[dict[str, Any]]]:
    """The synthetic participants' rows, their participant rows, and the simulation-only
    decisions."""
    people = participants(settings.pool_participants, PLAN_BLOCK, settings.cells)
    rows = pooled(
        run_participants(
            people,
            population,
            params,
            workers,
            dask_address,
            settings.trial_s,
            on_done=progress,
        )
    )
    people_rows = [
        {
            "participant": p.code,
            "study": settings.study,
            "cell": p.cell,
            "model_order": ",".join(model for model, _ in p.arms),
            "is_pilot": False,
            "is_bot": False,
            "is_demo": False,
            "status": "completed",
        }
        for p in people
    ]
    scenarios = exp.experiment_scenarios(settings.pool_scenarios, SIMULATION_BLOCK, params)
    jobs = exp.jobs_for(scenarios, ("M1", "M2"), settings.scenario_runs)
    simulated = exp.run_jobs(jobs, workers, dask_address, on_done=progress, params=params)
    return rows, people_rows, simulated


def write_export(
    directory: Path,
    rows: TrialRows,
    people: list[dict[str, Any]],
    simulated: list[dict[str, Any]],
) -> None:
    """The pool as an export directory `hcss analyze` reads (the data dictionary's columns)."""
    write_rows(directory / "decisions.csv", DECISIONS.names, [*rows.decisions, *simulated])
    write_rows(directory / "participants.csv", EXPORT_TABLES["participants"].names, people)
    for table in ("requests", "observations", "probes"):
        names = EXPORT_TABLES[table].names
        write_rows(
            directory / f"{table}.csv",
            names,
            ({k: row.get(k) for k in names} for row in getattr(rows, table)),
        )


def replicate(
    pool: pw.UnitPool,
    settings: PlanSettings,
    workers: int,
    dask_address: str | None,
    chunk: int = 50,
    progress: Callable[[], None] | None = None,
) -> list[pw.PowerPoint]:
    """Every N's replications, in chunks over the workers; seeds from the plan's seed."""
    jobs = [
        (n, min(chunk, settings.replications - start), settings.seed * 1_000_003 + n * 10_007 + i)
        for n in settings.ns
        for i, start in enumerate(range(0, settings.replications, chunk))
    ]
    counts: dict[int, dict[pw.Hypothesis, int]] = {n: {} for n in settings.ns}
    for (n, _, _), result in _execute(pool, jobs, settings.alpha, workers, dask_address):
        for h, k in result.items():
            counts[n][h] = counts[n].get(h, 0) + k
        if progress is not None:
            progress()
    return pw.power_points(counts, dict.fromkeys(settings.ns, settings.replications))


def _chunk(pool: pw.UnitPool, job: tuple[int, int, int], alpha: float) -> dict[pw.Hypothesis, int]:
    n, replications, seed = job
    return pw.rejections(pool, n, replications, seed, alpha)


def _execute(
    pool: pw.UnitPool,
    jobs: list[tuple[int, int, int]],
    alpha: float,
    workers: int,
    dask_address: str | None,
) -> Iterator[tuple[tuple[int, int, int], dict[pw.Hypothesis, int]]]:
    if dask_address:
        with exp.dask_client(dask_address, workers) as client:
            scattered = client.scatter(pool, broadcast=True)
            submitted = [client.submit(_chunk, scattered, job, alpha, pure=False) for job in jobs]
            for index, result in exp.completed_in_order_of(submitted):
                yield jobs[index], result
    elif workers <= 1:
        for job in jobs:
            yield job, _chunk(pool, job, alpha)
    else:
        with ProcessPoolExecutor(max_workers=workers) as executor:
            futures = {executor.submit(_chunk, pool, job, alpha): job for job in jobs}
            for future in as_completed(futures):
                yield futures[future], future.result()


def run_plan(
    out: Path,
    settings: PlanSettings,
    population: Population,
    params: Params,
    workers: int = 2,
    dask_address: str | None = None,
    progress: Callable[[str], None] | None = None,
) -> Plan:
    """Simulate the pool, analyse its export with `hcss analyze`, resample, write plan.html."""
    from hcss.analysis.report import run_analysis

    say = progress or (lambda _message: None)
    timings: dict[str, float] = {}
    started = time.perf_counter()
    say("simulating the pool")
    rows, people, simulated = simulate_pool(settings, population, params, workers, dask_address)
    timings["pool"] = time.perf_counter() - started
    write_export(out / "export", rows, people, simulated)
    say("analysing the pool's export with hcss analyze")
    mark = time.perf_counter()
    report = run_analysis([out / "export"], out / "analysis", progress=False)
    timings["analysis"] = time.perf_counter() - mark
    measures = pd.read_csv(out / "analysis" / "measures.csv")
    say("resampling")
    mark = time.perf_counter()
    points = replicate(pw.unit_pool(measures), settings, workers, dask_address)
    by_trial = teams.values_by_trial(rows.decisions, rows.requests, rows.observations, rows.probes)
    reproduced = study_claims.reproduction(
        by_trial,
        rows.participant_of(),
        simulated,
        settings.ns,
        settings.replications,
        settings.seed,
    )
    timings["power"] = time.perf_counter() - mark
    timings["total"] = time.perf_counter() - started
    measured = teams.summarise(by_trial)
    alone = {key: m.success_pct for key, m in study_targets.measure(simulated).items()}
    plan = Plan(settings, points, measured, report.html_path, timings, alone, reproduced)
    write_plan(out, plan, params)
    return plan


# ------------------------------------------------------------------ output
#: The hypotheses drawn in the figure: the omnibus test and the study's headline pairs.
FIGURED = (
    pw.Hypothesis("kruskal_wallis", "success_rate", "overall"),
    pw.Hypothesis("kruskal_wallis", "decision_time_min", "overall"),
    pw.Hypothesis("mann_whitney", "success_rate", "difficult", ("M1", "M2")),
    pw.Hypothesis("mann_whitney", "decision_time_min", "easy", ("M1", "M2")),
    pw.Hypothesis("tukey_kramer", "success_rate", "difficult", ("M1SIM", "M1")),
    pw.Hypothesis("tukey_kramer", "decision_time_min", "overall", ("M2", "M3")),
)


def assumptions(settings: PlanSettings, params: Params) -> list[str]:
    return [
        f"Operators: synthetic participants drawn from {settings.population}; each acts only "
        "on what the interface shows (hcss.simulation.synthetic). They are simulated "
        "operators, not people: a real sample can differ in ways the fit to §11's means "
        "does not capture (learning, fatigue, strategies outside the operator's rules).",
        f"Model: preset {params.preset}; live trials' rules (no per-decision time-out), "
        f"trials of {settings.trial_s:g} s ending whatever is under way.",
        f"Design: study file '{settings.study}', {len(settings.cells)} counterbalancing cells "
        "filled in turn; training trials are not simulated (the operator does not learn).",
        f"Pool: {settings.pool_participants} synthetic participants (seeds from "
        f"{PLAN_BLOCK}), {settings.pool_scenarios} simulation-only scenarios × "
        f"{settings.scenario_runs} runs per model (seeds from {SIMULATION_BLOCK}); a "
        "simulation-only unit is a scenario's mean over its runs, as the analysis makes it "
        "(the study's units were means over 10 runs: with fewer, a unit varies more and the "
        "simulation-only groups' power is underestimated; --runs 10 costs more).",
        "Resampling: per replication N participants (with all their trials) and N scenarios "
        "per simulation-only model, with replacement from the pool, which stands for the "
        "population (a pool much larger than N keeps repeats rare); the simulation-only "
        "condition is assumed run with as many scenarios as participants.",
        f"Tests: the analysis's own (hcss.analysis.stats, posthoc), two-sided, alpha = "
        f"{settings.alpha:g}, unadjusted for the number of hypotheses; Tukey-Kramer on mean "
        "ranks over the five groups; Mann-Whitney with R's wilcox.test rule.",
        f"Monte Carlo: {settings.replications} replications per N; intervals are "
        "Clopper-Pearson 95% intervals of the share rejected.",
        "Predicted tables: the whole pool analysed by hcss analyze (its report is linked); "
        "synthetic participants are source = synthetic, never pooled with real ones.",
    ]


def figured(points: Sequence[pw.PowerPoint], most: int = 6) -> list[pw.Hypothesis]:
    """The omnibus tests on success and time, then the hypotheses whose power moves most
    over the grid (the ones N decides; flat curves at 0 or 1 say little in a figure)."""
    by: dict[pw.Hypothesis, list[float]] = {}
    for p in points:
        by.setdefault(p.hypothesis, []).append(p.power)
    moving = sorted(
        (h for h in by if h.test != "kruskal_wallis"),
        key=lambda h: max(by[h]) - min(by[h]),
        reverse=True,
    )
    return [*FIGURED[:2], *moving[:most]]


def _figure_png(points: Sequence[pw.PowerPoint]) -> str:
    buffer = io.BytesIO()
    pw.power_figure(points, figured(points)).savefig(buffer, format="png", dpi=110)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def write_plan(out: Path, plan: Plan, params: Params) -> Path:
    """plan.html (and plan.json, power.csv) in OUT."""
    out.mkdir(parents=True, exist_ok=True)
    table = pw.power_table(plan.points)
    write_frame(out / "power.csv", table)
    figure = _figure_png(plan.points)
    (out / "power.png").write_bytes(base64.b64decode(figure))
    (out / "plan.json").write_text(
        json.dumps(
            {"settings": asdict(plan.settings), "timings_s": plan.timings}, indent=2, default=str
        ),
        encoding="utf-8",
    )
    comparison = teams.comparison_markdown(plan.measured)
    body = [
        "<h1>Study plan: predicted results and power</h1>",
        f"<p>Run time {plan.timings.get('total', 0) / 60:.1f} min (pool "
        f"{plan.timings.get('pool', 0) / 60:.1f}, analysis "
        f"{plan.timings.get('analysis', 0) / 60:.1f}, power "
        f"{plan.timings.get('power', 0) / 60:.1f}). The predicted paper tables: "
        f'<a href="{html.escape(str(plan.analysis_html.relative_to(out)))}">'
        "hcss analyze's report of the pool</a>.</p>",
        "<h2>Assumptions</h2><ul>",
        *(f"<li>{html.escape(a)}</li>" for a in assumptions(plan.settings, params)),
        "</ul>",
        "<h2>Power curves</h2>",
        f'<img alt="power against N" src="data:image/png;base64,{figure}">',
        "<h2>Power per test (Monte Carlo 95% interval) and the N for 80%</h2>",
        table.to_html(index=False, escape=True),
        "<h2>Predicted per-decision tables beside the study's (SPEC-simulation.md §11)</h2>",
        _markdown_table_html(comparison),
        "<h2>The study's words about its operators, on the predicted teams</h2>",
        "<p>Held back from the calibration, which fits each cell alone; collectives alone "
        "are the simulation-only pool.</p>",
        _markdown_table_html(
            study_claims.claims_markdown(study_claims.claims(plan.measured, plan.alone))
        ),
        "<h3>The chance that a study of N participants bears out each</h3>",
        "<p>Its means on N participants and N simulation-only scenarios drawn from the pool "
        f"({plan.settings.replications} replications), as the power above.</p>",
        _markdown_table_html(study_claims.reproduction_markdown(plan.reproduced)),
    ]
    page = (
        "<!doctype html><html lang='en'><head><meta charset='utf-8'><title>hcss plan</title>"
        "<style>body{font-family:sans-serif;margin:2em}table{border-collapse:collapse;"
        "font-size:12px}td,th{border:1px solid #ccc;padding:2px 6px}</style></head><body>"
        + "\n".join(body)
        + "</body></html>"
    )
    path = out / "plan.html"
    path.write_text(page, encoding="utf-8")
    return path


def _markdown_table_html(markdown: str) -> str:
    lines = [line.strip().strip("|").split("|") for line in markdown.splitlines()]
    head, rows = lines[0], lines[2:]
    cells = "".join(f"<th>{html.escape(c.strip())}</th>" for c in head)
    body = "".join(
        "<tr>" + "".join(f"<td>{html.escape(c.strip())}</td>" for c in row) + "</tr>"
        for row in rows
    )
    return f"<table><tr>{cells}</tr>{body}</table>"


def summary(plan: Plan) -> str:
    """The N for 80% power of the omnibus tests and the headline pairs, as text."""
    reached = pw.n_for_power(plan.points)
    lines = ["N for 80% power (grid " + ", ".join(map(str, plan.settings.ns)) + "):"]
    for h in FIGURED:
        n = reached.get(h)
        lines.append(f"  {h.label}: {'beyond the grid' if n is None else n}")
    return "\n".join(lines)
