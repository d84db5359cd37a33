"""The simulation-only experiment: scenarios × runs × models, no operator.

The study ran 28 trial scenarios (half starting easy, half difficult) 10 times
each with M1 and with M2. Jobs are independent, so they run on a local process
pool or, for sweeps that outgrow one machine, on Dask distributed.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hcss.simulation.engine import Simulation
from hcss.simulation.params import Params
from hcss.simulation.scenario import Scenario
from hcss.tablespec import DECISIONS
from hcss.tidy_csv import write_rows

SPLITS = ("overall", "easy", "difficult")
DEFAULT_SCENARIO_SEED = 20_150_000  # the experiment's scenario block; calibrations search on it


@dataclass(frozen=True)
class Job:
    """One simulation run: a scenario, a model and a replicate number."""

    scenario: dict[str, Any]  # Scenario.to_dict(): plain values travel to workers cheaply
    model: str
    run: int
    operator: str | None = None  # a scripted operator (operators.OPERATORS), or none

    @property
    def trial_id(self) -> str:
        base = f"{self.scenario['scenario_id']}-{self.model}-r{self.run}"
        return base if self.operator is None else f"simop-{self.operator}-{base}"

    @property
    def participant(self) -> str:
        """A simulated operator stands in for a participant: one per scenario and run."""
        if self.operator is None:
            return ""
        return f"simop-{self.operator}-{self.scenario['scenario_id']}-r{self.run}"


def experiment_scenarios(
    n: int = 28, base_seed: int = DEFAULT_SCENARIO_SEED, params: Params | None = None
) -> list[Scenario]:
    """n scenarios with fixed seeds, alternating easy-first and difficult-first.

    `params` are the run's (a preset's): the layout readings among them
    (`easy_layout_others`) shape the scenarios.
    """
    return [
        Scenario.generate(
            base_seed + i,
            first_section="easy" if i % 2 == 0 else "difficult",
            scenario_id=f"exp{i + 1:02d}",
            params=params,
        )
        for i in range(n)
    ]


def jobs_for(
    scenarios: Iterable[Scenario], models: Iterable[str], runs: int, operator: str | None = None
) -> list[Job]:
    return [
        Job(s.to_dict(), m, r, operator) for s in scenarios for m in models for r in range(runs)
    ]


def run_job(job: Job, params: Params | None = None) -> list[dict[str, Any]]:
    """Run one trial to completion and return its decisions-table rows.

    With an operator, the trial is an operated one (the human-team condition,
    simulated): the scripted operator's requests go through the request API
    and its rows are `source="study"` rows of a simulated participant (code
    `simop-...`), so `hcss analyze --include-pilot` gives the human-team tables.
    """
    sim = Simulation(Scenario.from_dict(job.scenario), job.model, params, run=job.run)
    if job.operator is None:
        sim.run_until_finished()
        source = "simulation"
    else:
        from hcss.simulation.operators import OperatedRun, operator_named

        policy, interval, pace = operator_named(job.operator)
        OperatedRun(sim, policy, interval_s=interval, pace=pace).run()
        source = "study"
    return [
        d.as_row(source=source, participant=job.participant, trial_id=job.trial_id, run=job.run)
        for d in sim.decisions
    ]


def run_jobs(
    jobs: list[Job],
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[], None] | None = None,
    params: Params | None = None,
) -> list[dict[str, Any]]:
    """Run every job and return all rows, in job order whatever order they finish in.

    `params` (default: `Params()`) applies to every job: M1, M2 and M3 share them.
    """
    results: dict[int, list[dict[str, Any]]] = {}
    for index, rows in _execute(jobs, workers, dask_address, params):
        results[index] = rows
        if on_done is not None:
            on_done()
    return [row for index in range(len(jobs)) for row in results[index]]


def _execute(
    jobs: list[Job], workers: int, dask_address: str | None, params: Params | None = None
) -> Iterator[tuple[int, list[dict[str, Any]]]]:
    if dask_address:
        yield from _execute_dask(jobs, workers, dask_address, params)
    elif workers <= 1:
        for index, job in enumerate(jobs):
            yield index, run_job(job, params)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(run_job, job, params): index for index, job in enumerate(jobs)}
            for future in as_completed(futures):
                yield futures[future], future.result()


@contextmanager
def dask_client(address: str, workers: int) -> Iterator[Any]:
    """A Dask client on the scheduler at `address`, or on a LocalCluster of `workers` processes
    when the address is "local"; closed (with its cluster) when the block ends."""
    from dask.distributed import Client, LocalCluster

    cluster = None
    if address == "local":
        cluster = LocalCluster(
            n_workers=max(1, workers), threads_per_worker=1, processes=True, dashboard_address=None
        )
        client = Client(cluster)
    else:
        client = Client(address)
    try:
        yield client
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def completed_in_order_of(futures: list[Any]) -> Iterator[tuple[int, Any]]:
    """(index in `futures`, result) as each Dask future completes."""
    from dask.distributed import as_completed as dask_completed

    index_of = {future.key: i for i, future in enumerate(futures)}
    for future in dask_completed(futures):
        yield index_of[future.key], future.result()


def _execute_dask(
    jobs: list[Job], workers: int, address: str, params: Params | None = None
) -> Iterator[tuple[int, list[dict[str, Any]]]]:
    """Run the jobs on a Dask scheduler, or on a LocalCluster when the address is "local"."""
    with dask_client(address, workers) as client:
        yield from completed_in_order_of(client.map(run_job, jobs, params=params, pure=False))


# ----------------------------------------------------------------- output
def write_decisions(rows: list[dict[str, Any]], path: Path) -> None:
    """The decisions table as CSV, with its contract's columns (hcss.tablespec.DECISIONS)."""
    write_rows(path, DECISIONS.names, rows)


def parse_changes(changes: Iterable[str]) -> dict[str, Any]:
    """`NAME=VALUE` texts as changes of Params: numbers, '+'-joined sets for tuple values
    (m2_modulation_uses, m2_mechanisms), text for readings; an unknown name is refused."""
    fields = Params.__dataclass_fields__
    defaults = Params()
    parsed: dict[str, Any] = {}
    for text in changes:
        name, sep, value = text.partition("=")
        name = name.strip()
        if not sep or name not in fields:
            raise ValueError(f"{text!r} is not NAME=VALUE with NAME a parameter")
        current = getattr(defaults, name)
        if isinstance(current, tuple):
            kind = type(current[0]) if current else str
            parsed[name] = tuple(kind(v) for v in value.split("+") if v)
        elif isinstance(current, bool) or current is None:
            raise ValueError(f"{name} cannot be set here")
        elif isinstance(current, int | float):
            parsed[name] = type(current)(value)
        else:
            parsed[name] = value
    return parsed
