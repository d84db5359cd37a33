"""Simulation benchmarks: real-time factor, the full experiment, and cost per step.

Figures are printed, never asserted: performance is measured here, not in the
unit tests.
"""

from __future__ import annotations

import os
import statistics
import sys
import threading
import time
from pathlib import Path

from hcss.simulation import Params, Scenario, Simulation
from hcss.simulation import experiment as exp


def real_time_factor(repeats: int = 3) -> None:
    """(1) Simulated seconds per wall second of one 4 × 200 trial on one core."""
    factors = []
    for seed in range(repeats):
        sim = Simulation(
            Scenario.generate(100 + seed, first_section="easy" if seed % 2 == 0 else "difficult"),
            "M1",
        )
        started = time.perf_counter()
        sim.run_until_finished()
        factors.append(sim.time / (time.perf_counter() - started))
    m2 = Simulation(Scenario.generate(100), "M2")
    started = time.perf_counter()
    m2.run_until_finished()
    m2_factor = m2.time / (time.perf_counter() - started)
    print(
        f"(1) real-time factor, one 4x200 trial, one core: M1 median {statistics.median(factors):,.0f}x "
        f"(runs {', '.join(f'{f:,.0f}' for f in factors)}), M2 {m2_factor:,.0f}x   [target >= 2,000x]"
    )


def step_cost(steps: int = 400) -> None:
    """(3) Time per step() for 1, 4 and 16 collectives of 200 agents."""
    parts = []
    for n in (1, 4, 16):
        side = max(1414.0, 1414.0 * (n / 4) ** 0.5 + 100.0)
        params = Params().with_changes(arena_side_m=side)
        sim = Simulation(Scenario.generate(7, n_collectives=n, params=params), "M1", params)
        sim.step(60)  # past the start, when everyone is in the hub
        started = time.perf_counter()
        sim.step(steps)
        per_step = (time.perf_counter() - started) / steps
        parts.append(f"{n:>2} collectives ({n * 200:>4} agents): {per_step * 1e6:7.0f} us/step")
    print("(3) cost per step:\n      " + "\n      ".join(parts))


def full_experiment(workers: int = 2) -> None:
    """(2) Wall time and peak memory of the full 28 x 10 x 2 experiment on `workers` processes."""
    jobs = exp.jobs_for(exp.experiment_scenarios(28), ["M1", "M2"], 10)
    sampler = _TreeMemory()
    sampler.start()
    started = time.perf_counter()
    rows = exp.run_jobs(jobs, workers=workers)
    elapsed = time.perf_counter() - started
    sampler.stop()
    out = Path("out/bench-experiment")
    exp.write_decisions(rows, out / "decisions.csv")
    table = exp.summary_table(out / "decisions.csv")
    (out / "summary.md").write_text(
        f"# Simulation-only experiment (make bench)\n\n{table}\n", encoding="utf-8"
    )
    print(
        f"(2) full simulation-only experiment ({len(jobs)} runs, {len(rows)} decisions, {workers} workers): "
        f"{elapsed / 60:.1f} min wall, peak memory {sampler.peak_mib:,.0f} MiB (all processes)   "
        f"[targets < 10 min, < 1 GB]; decisions in {out}/decisions.csv"
    )
    print(table)


class _TreeMemory:
    """Samples the resident memory of this process and its children (Linux /proc)."""

    def __init__(self, every_s: float = 0.2):
        self.every_s = every_s
        self.peak_mib = 0.0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()

    def _run(self) -> None:
        while not self._stop.is_set():
            self.peak_mib = max(self.peak_mib, _tree_rss_kib(os.getpid()) / 1024)
            self._stop.wait(self.every_s)


def _tree_rss_kib(pid: int) -> int:
    total = 0
    try:
        with open(f"/proc/{pid}/status") as status:
            for line in status:
                if line.startswith("VmRSS:"):
                    total += int(line.split()[1])
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as children:
                for child in children.read().split():
                    total += _tree_rss_kib(int(child))
    except (FileNotFoundError, ProcessLookupError):
        pass
    return total


def run() -> None:
    print(f"python {sys.version.split()[0]}, {os.cpu_count()} cores")
    real_time_factor()
    step_cost()
    full_experiment()
