"""Analysis benchmarks: the studentized range p, and `hcss analyze` on a study-sized input.

Figures are printed, never asserted.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

from scipy.stats import studentized_range

from hcss.analysis.r_distributions import tukey_sf
from hcss.analysis.report import run_analysis
from tests.analysis.synthetic import simulation_decisions, study_export, write_table


def studentized_range_p(repeats: int = 50) -> None:
    """(1) One Tukey HSD p (k = 3, df = 33): R's ptukey port vs scipy's integral."""
    started = time.perf_counter()
    for index in range(repeats):
        tukey_sf(2.0 + index / repeats, 3, 33.0)
    ours = (time.perf_counter() - started) / repeats
    started = time.perf_counter()
    for index in range(repeats):
        studentized_range.sf(2.0 + index / repeats, 3, 33.0)
    theirs = (time.perf_counter() - started) / repeats
    print(f"(1) Tukey p per call: R's ptukey port {ours * 1e3:.2f} ms, scipy {theirs * 1e3:.1f} ms")


def full_report(participants: int = 36) -> None:
    """(2) `hcss analyze` on a study of `participants` plus the 28 x 10 x 2 simulation."""
    with tempfile.TemporaryDirectory() as scratch:
        base = Path(scratch)
        export = study_export(base / "export", participants=participants)
        write_table(
            simulation_decisions(scenarios=28, runs=10), base / "simulation" / "decisions.csv"
        )
        wall, cpu = time.perf_counter(), time.process_time()
        report = run_analysis([base / "simulation", export], base / "report", progress=False)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(
        f"(2) hcss analyze, {participants} participants + 560 simulation runs: {wall:.1f} s wall, "
        f"{cpu:.1f} s CPU; {len(report.tables)} tables, {len(report.figures)} figures"
    )


def run() -> None:
    studentized_range_p()
    full_report()
