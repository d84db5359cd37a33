"""Parameter sweeps: the simulation-only experiment over a grid of parameter values.

A sweep names some parameters of `Params` and a few values for each; every
combination (cell) runs the experiment (scenarios × runs × models, no
operator) with those values, everything else at its default. M1, M2 and M3
share every value of a cell.

Output directory:

    sweep.json           what was swept and the experiment's settings
    cells/<cell>.csv     one file per finished cell, written atomically
    decisions.csv        every cell's decisions, one row per decision, the
                         cell's parameter values as the first columns

A cell whose file exists is not run again, so an interrupted sweep resumes
where it stopped; resuming with other settings is refused rather than mixing
two sweeps in one table. Cells run on local processes or on Dask.
"""

from __future__ import annotations

import itertools
import json
import os
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from hcss.experiments import experiment as exp
from hcss.simulation.params import Params
from hcss.simulation.presets import DEFAULT_PRESET, preset_params
from hcss.tablespec import SWEEP_DECISIONS
from hcss.tidy_csv import TableWriter, write_rows

MANIFEST = "sweep.json"
CELLS = "cells"
MAX_CELLS = 10_000


class SweepError(ValueError):
    """A sweep that cannot run as asked (bad parameter, bad value, other settings)."""


@dataclass(frozen=True)
class Axis:
    """One swept parameter and its values, in the order given."""

    name: str
    values: tuple[object, ...]


def parse_axis(spec: str) -> Axis:
    """'name=v1,v2,...' into an Axis, with values of the parameter's own type.

    Every value is checked by building Params with it, so an impossible value
    (a negative rate, an unknown reading) is refused before anything runs.
    """
    name, sep, raw = spec.partition("=")
    name = name.strip()
    if not sep or not name or not raw.strip():
        raise SweepError(f"{spec!r}: write a parameter as name=value1,value2,...")
    kinds = {f.name: f.type for f in fields(Params)}
    if name not in kinds:
        raise SweepError(f"{name!r} is not a simulation parameter")
    default = getattr(Params(), name)
    if isinstance(default, tuple | type(None)) or name in ("dt_s", "preset"):
        raise SweepError(f"{name!r} cannot be swept (only single-valued parameters, dt fixed)")
    values = []
    for text in raw.split(","):
        text = text.strip()
        try:
            value = _typed(text, default)
            Params().with_changes(**{name: value})
        except (TypeError, ValueError) as error:
            raise SweepError(f"{name}={text!r}: {error}") from None
        if value in values:
            raise SweepError(f"{name} lists {text!r} twice")
        values.append(value)
    return Axis(name, tuple(values))


def _typed(text: str, default: object) -> object:
    if isinstance(default, bool):
        raise TypeError("boolean parameters cannot be swept")
    if isinstance(default, int):
        return int(text)
    if isinstance(default, float):
        value = float(text)
        if value != value or value in (float("inf"), float("-inf")):
            raise ValueError("not a finite number")
        return value
    if len(text) > 100 or not text.isprintable():
        raise ValueError("not a valid value")
    return text


def grid(axes: list[Axis]) -> list[dict[str, object]]:
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        raise SweepError("a parameter is swept twice")
    cells = [
        dict(zip(names, combo, strict=True))
        for combo in itertools.product(*(a.values for a in axes))
    ]
    if len(cells) > MAX_CELLS:
        raise SweepError(f"{len(cells)} cells; a sweep is limited to {MAX_CELLS}")
    return cells


def cell_name(cell: dict[str, object]) -> str:
    """A file name for a cell: 'message_rate=0.5__quorum_k=10'."""
    return "__".join(f"{name}={value}" for name, value in cell.items())


@dataclass(frozen=True)
class Sweep:
    axes: tuple[Axis, ...]
    scenarios: int
    runs: int
    models: tuple[str, ...]
    seed: int
    preset: str = DEFAULT_PRESET  # every value not swept is this preset's

    def manifest(self) -> dict[str, Any]:
        return {
            "preset": self.preset,
            "parameters": {a.name: list(a.values) for a in self.axes},
            "scenarios": self.scenarios,
            "runs": self.runs,
            "models": list(self.models),
            "seed": self.seed,
        }

    @property
    def cells(self) -> list[dict[str, object]]:
        return grid(list(self.axes))

    def jobs(self, cell: dict[str, object] | None = None) -> list[exp.Job]:
        """The runs of one cell (the same number for every cell): its scenarios are drawn
        under the cell's params, whose layout readings may shape them."""
        params = preset_params(self.preset).with_changes(**(cell or {}))
        return exp.jobs_for(
            exp.experiment_scenarios(self.scenarios, self.seed, params), self.models, self.runs
        )

    @property
    def columns(self) -> tuple[str, ...]:
        """The columns of its tables: hcss.tablespec.SWEEP_DECISIONS with its axes named."""
        return SWEEP_DECISIONS.expand(parameter=[a.name for a in self.axes])


def prepare(sweep: Sweep, out: Path) -> list[dict[str, object]]:
    """Create or reopen OUT; the cells still to run."""
    manifest = out / MANIFEST
    if manifest.exists():
        try:
            existing = json.loads(manifest.read_text(encoding="utf-8"))
        except (OSError, ValueError) as error:
            raise SweepError(f"{manifest} is not a sweep manifest: {error}") from None
        if existing != json.loads(json.dumps(sweep.manifest())):
            raise SweepError(
                f"{out} holds another sweep ({manifest}); use a new --out to run this one"
            )
    elif out.exists() and any(out.iterdir()):
        raise SweepError(f"{out} exists and is not a sweep directory; use a new --out")
    (out / CELLS).mkdir(parents=True, exist_ok=True)
    if not manifest.exists():
        _write_atomic(manifest, json.dumps(sweep.manifest(), indent=2) + "\n")
    return [c for c in sweep.cells if not (out / CELLS / f"{cell_name(c)}.csv").exists()]


def run_sweep(
    sweep: Sweep,
    out: Path,
    workers: int = 1,
    dask_address: str | None = None,
    on_done: Callable[[int], None] | None = None,
) -> int:
    """Run every cell not yet written, then write decisions.csv. Returns the cells run.

    `on_done(n)` is called after every finished run (n = 1) and, for cells
    already written, once with their number of runs.
    """
    pending = prepare(sweep, out)
    jobs = sweep.jobs()
    skipped = len(sweep.cells) - len(pending)
    if on_done is not None and skipped:
        on_done(skipped * len(jobs))
    tasks = [(job, cell) for cell in pending for job in sweep.jobs(cell)]
    finished: dict[str, dict[int, list[dict[str, Any]]]] = {cell_name(c): {} for c in pending}
    for index, rows in _execute(tasks, workers, dask_address, sweep.preset):
        cell = tasks[index][1]
        done = finished[cell_name(cell)]
        done[index] = rows
        if on_done is not None:
            on_done(1)
        if len(done) == len(jobs):  # the cell is complete: write it, in job order
            _write_cell(out, sweep, cell, [row for i in sorted(done) for row in done[i]])
            del finished[cell_name(cell)]
    combine(out, sweep)
    return len(pending)


def _run_task(job: exp.Job, cell: dict[str, object], preset: str) -> list[dict[str, Any]]:
    return exp.run_job(job, preset_params(preset).with_changes(**cell))


def _execute(
    tasks: list[tuple[exp.Job, dict[str, Any]]], workers: int, dask_address: str | None, preset: str
) -> Iterator[tuple[int, list[dict[str, Any]]]]:
    """Run (job, cell) tasks, yielding (index, rows) as they finish."""
    if not tasks:
        return
    if dask_address:
        yield from _execute_dask(tasks, workers, dask_address, preset)
    elif workers <= 1:
        for index, (job, cell) in enumerate(tasks):
            yield index, _run_task(job, cell, preset)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {
                pool.submit(_run_task, job, cell, preset): index
                for index, (job, cell) in enumerate(tasks)
            }
            for future in as_completed(futures):
                yield futures[future], future.result()


def _execute_dask(
    tasks: list[tuple[exp.Job, dict[str, Any]]], workers: int, address: str, preset: str
) -> Iterator[tuple[int, list[dict[str, Any]]]]:
    """On a Dask scheduler, or on a LocalCluster of `workers` processes when address is "local"."""
    with exp.dask_client(address, workers) as client:
        futures = client.map(
            _run_task,
            [job for job, _ in tasks],
            [cell for _, cell in tasks],
            preset=preset,
            pure=False,
        )
        yield from exp.completed_in_order_of(futures)


def _write_cell(
    out: Path, sweep: Sweep, cell: dict[str, object], rows: list[dict[str, Any]]
) -> None:
    path = out / CELLS / f"{cell_name(cell)}.csv"
    tmp = path.with_suffix(".csv.tmp")
    write_rows(tmp, sweep.columns, ({**cell, **row} for row in rows))
    os.replace(tmp, path)


def combine(out: Path, sweep: Sweep) -> Path:
    """decisions.csv: every cell's rows, cells in grid order."""
    path = out / "decisions.csv"
    tmp = path.with_suffix(".csv.tmp")
    with tmp.open("w", newline="", encoding="utf-8") as handle:
        TableWriter(handle, sweep.columns)  # the header
        for cell in sweep.cells:
            # Each cell's file was written by the same writer: its rows are copied as they are.
            cell_file = out / CELLS / f"{cell_name(cell)}.csv"
            with cell_file.open(newline="", encoding="utf-8") as part:
                part.readline()  # header
                for line in part:
                    handle.write(line)
    os.replace(tmp, path)
    return path


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_suffix(path.suffix + ".tmp")
    tmp.write_text(text, encoding="utf-8")
    os.replace(tmp, path)
