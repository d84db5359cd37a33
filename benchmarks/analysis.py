"""Analysis benchmarks: the studentized range p, and `hcss analyze` on a study-sized input.

Figures are printed, never asserted.
"""

from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from scipy.stats import studentized_range

from hcss.analysis.r_distributions import tukey_sf
from hcss.analysis.report import run_analysis
from tests.support.synthetic import simulation_decisions, study_export, write_table


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


@dataclass(frozen=True)
class _Measured:
    returncode: int
    stderr: str
    peak_kb: int


def _run_measured(command: list[str], stderr_path: Path) -> _Measured:
    """Run `command` and read its own peak resident memory from wait4, through a small
    launcher process.

    Not RUSAGE_CHILDREN: that is the largest child this process ever had, and the
    simulation pool that made the benchmark's decisions has larger ones. Nor this
    process's own child: a child's high-water mark starts from the fork of this
    (large) process before its exec, so a small launcher forks the command.
    """
    launcher = (
        "import os, subprocess, sys\n"
        "child = subprocess.Popen(sys.argv[1:], stdout=subprocess.DEVNULL)\n"
        "_, status, usage = os.wait4(child.pid, 0)\n"
        "print(usage.ru_maxrss, os.waitstatus_to_exitcode(status))\n"
    )
    with stderr_path.open("w") as stderr:
        done = subprocess.run(
            [sys.executable, "-c", launcher, *command],
            stdout=subprocess.PIPE,
            stderr=stderr,
            text=True,
            check=False,
        )
    peak_kb, returncode = (int(word) for word in done.stdout.split())
    return _Measured(returncode, stderr_path.read_text(), peak_kb)


def large_decisions_file(scenarios: int = 420, runs: int = 10) -> None:
    """(3) `hcss analyze` as a user runs it, on one decisions CSV of 100,800 decisions.

    The command runs in its own process, so its peak resident memory is the
    child's (``ru_maxrss``) and its time includes start-up and writing the report.
    """
    with tempfile.TemporaryDirectory() as scratch:
        base = Path(scratch)
        decisions = simulation_decisions(scenarios=scenarios, runs=runs)
        path = write_table(decisions, base / "decisions.csv")
        megabytes = path.stat().st_size / 1e6
        command = [sys.executable, "-c", "from hcss.cli import main; main()", "analyze"]
        command += [str(path), "--out", str(base / "report")]
        wall = time.perf_counter()
        completed = _run_measured(command, base / "stderr.txt")
        wall = time.perf_counter() - wall
        peak_mb = completed.peak_kb / 1024
        tables = len(list((base / "report" / "tables").glob("*.csv")))
    status = f"{tables} tables" if completed.returncode == 0 else f"exit {completed.returncode}"
    print(
        f"(3) hcss analyze, {len(decisions):,} decisions ({megabytes:.1f} MB CSV): "
        f"{wall:.1f} s wall, peak {peak_mb:.0f} MB resident ({status})"
    )
    if completed.returncode != 0:
        print(completed.stderr[-2000:])


def refused_large_file(gigabytes: float = 1.0) -> None:
    """(4) `hcss analyze` refusing a decisions CSV of 1 GB, as its own process.

    Every input check runs before the statistics libraries are imported, so the
    refusal costs the command's start-up and the check, not a full analysis's imports.
    """
    with tempfile.TemporaryDirectory() as scratch:
        path = Path(scratch) / "decisions.csv"
        with path.open("wb") as handle:  # sparse: the size is what the check reads first
            handle.truncate(int(gigabytes * 1e9))
        command = [sys.executable, "-c", "from hcss.cli import main; main()", "analyze"]
        command += [str(path), "--out", str(Path(scratch) / "report")]
        wall = time.perf_counter()
        completed = subprocess.run(command, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - wall
    refused = completed.returncode != 0 and "larger than a study export" in completed.stderr
    print(
        f"(4) hcss analyze on a {gigabytes:g} GB decisions file: "
        f"{'refused' if refused else 'NOT refused'} after {wall:.1f} s"
    )


def run() -> None:
    studentized_range_p()
    full_report()
    large_decisions_file()
    refused_large_file()
