"""Synthetic participants: each draws its traits from a population and runs the protocol's trials.

A participant is a seed and a counterbalancing cell (its models in the order
met, each with the section it starts with). Its traits come from
`Population.participant(seed)`; each of its trials gets its own scenario
(seeded from a block, so calibration and validation blocks never share one)
and a fresh `SyntheticOperator` (what it remembers does not carry over).
Training trials are not simulated: the operator does not learn [choice].

Participants are independent, so they run on a local process pool or on Dask,
as the simulation-only experiment's jobs do (`experiment.run_jobs`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

from hcss.experiments.experiment import completed_in_order_of, dask_client
from hcss.experiments.synthetic_trials import TRIAL_S, TrialRows, run_trial
from hcss.simulation.params import Params
from hcss.simulation.scenario import Scenario
from hcss.simulation.synthetic import Population, SyntheticOperator

#: The original design's eight cells (SPEC-study.md §4): M1 and M2 first in either order,
#: each starting easy or difficult, M3 last starting easy. `hcss plan` reads the study file's.
ORIGINAL_CELLS: tuple[tuple[tuple[str, str], ...], ...] = tuple(
    tuple((model, first[model]) for model in order)
    for order in (("M1", "M2", "M3"), ("M2", "M1", "M3"))
    for first in (
        {"M1": m1, "M2": m2, "M3": "easy"}
        for m1 in ("easy", "difficult")
        for m2 in ("easy", "difficult")
    )
)


@dataclass(frozen=True)
class SyntheticParticipant:
    """One synthetic participant: its code, seed, cell (1-based) and trials in the order met."""

    code: str
    seed: int
    cell: int
    arms: tuple[tuple[str, str], ...]  # (model, first section) per trial

    def scenario_seed(self, position: int) -> int:
        return self.seed * 8 + position


def participants(
    n: int,
    seed_block: int,
    cells: Sequence[tuple[tuple[str, str], ...]] = ORIGINAL_CELLS,
    prefix: str = "syn",
) -> list[SyntheticParticipant]:
    """n participants, balanced over the cells in turn (the least-filled cell first, as
    enrolment does, with ties broken by cell number rather than at random)."""
    return [
        SyntheticParticipant(
            f"{prefix}-{seed_block + i}", seed_block + i, i % len(cells) + 1, cells[i % len(cells)]
        )
        for i in range(n)
    ]


@dataclass(frozen=True)
class TeamJob:
    """What a worker needs to run one participant (plain values travel cheaply)."""

    participant: SyntheticParticipant
    population: dict[str, Any]
    params: dict[str, Any]
    duration_s: float = TRIAL_S
    probes: bool = True


def run_participant(job: TeamJob) -> TrialRows:
    """Every trial of one participant, in the order met; rows as the export has them."""
    p = job.participant
    traits = Population.from_dict(job.population).participant(p.seed)
    params = Params.from_dict(job.params)
    rows = TrialRows()
    for position, (model, first) in enumerate(p.arms):
        seed = p.scenario_seed(position)
        scenario = Scenario.generate(seed, first_section=first, params=params)
        operator = SyntheticOperator(traits, seed)
        _, trial = run_trial(
            scenario,
            model,
            params,
            operator,
            p.code,
            f"{p.code}-{model}",
            job.duration_s,
            job.probes,
        )
        rows.extend(trial)
    return rows


def run_participants(
    people: Sequence[SyntheticParticipant],
    population: Population,
    params: Params,
    workers: int = 1,
    dask_address: str | None = None,
    duration_s: float = TRIAL_S,
    probes: bool = True,
    on_done: Callable[[], None] | None = None,
) -> list[TrialRows]:
    """Each participant's rows, in the order given, whatever order they finish in."""
    jobs = [TeamJob(p, population.to_dict(), params.to_dict(), duration_s, probes) for p in people]
    results: dict[int, TrialRows] = {}
    for index, rows in _execute(jobs, workers, dask_address):
        results[index] = rows
        if on_done is not None:
            on_done()
    return [results[i] for i in range(len(jobs))]


def _execute(
    jobs: list[TeamJob], workers: int, dask_address: str | None
) -> Iterator[tuple[int, TrialRows]]:
    if dask_address:
        with dask_client(dask_address, workers) as client:
            yield from completed_in_order_of(client.map(run_participant, jobs, pure=False))
    elif workers <= 1:
        for index, job in enumerate(jobs):
            yield index, run_participant(job)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(run_participant, job): i for i, job in enumerate(jobs)}
            for future in as_completed(futures):
                yield futures[future], future.result()


def pooled(results: Sequence[TrialRows]) -> TrialRows:
    rows = TrialRows()
    for r in results:
        rows.extend(r)
    return rows
