"""`hcss simulate`: a live demo and the simulation-only experiment."""

from __future__ import annotations

import time
from pathlib import Path

import click
from tqdm import tqdm

from hcss.simulation import experiment as exp
from hcss.simulation.engine import Simulation
from hcss.simulation.params import MODELS, ROMAN
from hcss.simulation.scenario import Scenario


@click.group()
def simulate() -> None:
    """Run the simulation: a live demo or the simulation-only experiment."""


@simulate.command()
@click.option("--model", type=click.Choice(MODELS), default="M1", show_default=True)
@click.option("--seed", type=int, default=1, show_default=True, help="Scenario seed.")
@click.option(
    "--first-section", type=click.Choice(["easy", "difficult"]), default="easy", show_default=True
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.1),
    default=30.0,
    show_default=True,
    help="Simulated seconds per wall-clock second (1 = live pace).",
)
@click.option(
    "--minutes",
    type=click.FloatRange(min=0.1),
    default=20.0,
    show_default=True,
    help="Trial length.",
)
def demo(model: str, seed: int, first_section: str, speed: float, minutes: float) -> None:
    """A four-collective trial, paced against the wall clock, with a live text summary."""
    sim = Simulation(Scenario.generate(seed, first_section=first_section), model, None)
    limit = minutes * 60.0
    click.echo(
        f"{model} trial, seed {seed}, {first_section} section first, {speed:g}x real time. Ctrl-C stops."
    )
    started = time.monotonic()
    bar = tqdm(total=int(limit), unit="sim s", desc="trial", dynamic_ncols=True)
    try:
        while not sim.finished and sim.time < limit:
            due = (time.monotonic() - started) * speed
            while sim.time < min(due, limit) and not sim.finished:
                sim.step()
            for event in sim.drain_events():
                bar.write(f"[{_clock(event['time'])}] {event['text']}")
            bar.set_postfix_str(_status(sim.view()), refresh=False)
            bar.update(int(sim.time) - bar.n)
            time.sleep(0.05)
    except KeyboardInterrupt:
        bar.write("stopped")
    bar.close()
    correct = sum(d.correct for d in sim.decisions)
    click.echo(
        f"{len(sim.decisions)} decisions, {correct} correct, in {_clock(sim.time)} of simulated time."
    )


@simulate.command()
@click.option("--scenarios", type=click.IntRange(min=1), default=28, show_default=True)
@click.option(
    "--runs",
    type=click.IntRange(min=1),
    default=10,
    show_default=True,
    help="Runs per scenario and model.",
)
@click.option("--models", default="M1,M2", show_default=True, help="Comma-separated models.")
@click.option(
    "--workers", type=click.IntRange(min=1), default=2, show_default=True, help="Local processes."
)
@click.option(
    "--dask",
    "dask_address",
    default=None,
    help="Dask scheduler address, or 'local' for a LocalCluster.",
)
@click.option(
    "--seed", type=int, default=20_150_000, show_default=True, help="Seed of the first scenario."
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/simulation"),
    show_default=True,
)
def experiment(
    scenarios: int,
    runs: int,
    models: str,
    workers: int,
    dask_address: str | None,
    seed: int,
    out: Path,
) -> None:
    """The simulation-only experiment: scenarios × runs × models, no operator.

    Writes OUT/decisions.csv, OUT/summary.md (and summary.csv/.tex, by hcss.analysis),
    and prints the summary.
    """
    chosen = [m.strip() for m in models.split(",") if m.strip()]
    unknown = [m for m in chosen if m not in MODELS]
    if unknown or not chosen:
        raise click.BadParameter(
            f"models must be among {', '.join(MODELS)}; got {models!r}", param_hint="--models"
        )
    jobs = exp.jobs_for(exp.experiment_scenarios(scenarios, seed), chosen, runs)
    where = f"Dask ({dask_address})" if dask_address else f"{workers} local process(es)"
    click.echo(
        f"{len(jobs)} runs ({scenarios} scenarios × {runs} runs × {', '.join(chosen)}) on {where}."
    )
    started = time.perf_counter()
    with tqdm(total=len(jobs), unit="run", desc="experiment", dynamic_ncols=True) as bar:
        rows = exp.run_jobs(jobs, workers, dask_address, on_done=bar.update)
    elapsed = time.perf_counter() - started
    out.mkdir(parents=True, exist_ok=True)
    exp.write_decisions(rows, out / "decisions.csv")
    table = exp.summary_table(out / "decisions.csv")
    (out / "summary.md").write_text(
        f"# Simulation-only experiment\n\n{len(jobs)} runs, {len(rows)} decisions, {elapsed:.0f} s.\n\n"
        "Unit: the scenario (each run's success rate and mean decision time, averaged over "
        "the scenario's runs), as `hcss analyze` computes it.\n\n"
        f"{table}\n",
        encoding="utf-8",
    )
    click.echo(table)
    click.echo(f"{len(rows)} decisions written to {out / 'decisions.csv'} in {elapsed:.0f} s.")


def _clock(seconds: float) -> str:
    return f"{int(seconds) // 60:02d}:{int(seconds) % 60:02d}"


def _status(view: dict) -> str:
    parts = []
    for c in view["collectives"]:
        f = c["fractions"]
        move = f"→{c['move']['target']}" if c["move"] else ""
        parts.append(
            f"{ROMAN[c['index']]} U{f['U']:.0%} F{f['F']:.0%} C{f['C']:.0%} X{f['X']:.0%}{move}"
        )
    return f"section {view['section']} | " + " | ".join(parts)
