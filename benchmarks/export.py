"""`hcss export` in a cold process against the console's zip in a warm server.

Both write the same tables (`write_export`); the console's zip runs in a
server whose modules and study files are already loaded, so the difference is
what a cold command pays before and beside the export itself. Figures are the
median of RUNS. The database is HCSS_EXPORT_BENCH_DB (a URL; e.g. one filled
by `hcss bots --n 34`), else 2 demo bots in a temporary SQLite file.
"""

from __future__ import annotations

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

RUNS = 3


def _bot_database(folder: Path) -> str:
    url = f"sqlite:///{folder / 'export-bench.sqlite3'}"
    subprocess.run(
        [sys.executable, "-m", "hcss.cli", "db", "upgrade"],
        env={**os.environ, "DATABASE_URL": url},
        check=True,
        capture_output=True,
    )
    subprocess.run(
        [sys.executable, "-m", "hcss.cli", "bots", "--n", "2", "--study", "demo"],
        env={**os.environ, "DATABASE_URL": url},
        check=True,
        capture_output=True,
    )
    return url


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def _cold_cli(url: str, folder: Path) -> tuple[float, float]:
    """One `hcss export` in a new process: (wall s, CPU s). On a shared machine the CPU
    time is the steadier figure: the wall time counts the other processes' turns too."""
    started, cpu = time.perf_counter(), _children_cpu()
    subprocess.run(
        [sys.executable, "-m", "hcss.cli", "export", str(folder / "cli"), "--replace"],
        env={**os.environ, "DATABASE_URL": url},
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - started, _children_cpu() - cpu


def _warm_zip(url: str) -> tuple[float, float]:
    """The console's zip (`export_archive`) in this process, after one warm-up: (wall s,
    CPU s)."""
    from hcss.platform.db import Database
    from hcss.platform.export.archive import export_archive

    database = Database(url)
    export_archive(database, "bench")
    started, cpu = time.perf_counter(), time.process_time()
    export_archive(database, "bench")
    elapsed = time.perf_counter() - started, time.process_time() - cpu
    database.engine.dispose()
    return elapsed


def run() -> None:
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        url = os.environ.get("HCSS_EXPORT_BENCH_DB") or _bot_database(folder)
        cli = [_cold_cli(url, folder) for _ in range(RUNS)]
        warm = [_warm_zip(url) for _ in range(RUNS)]
    load = os.getloadavg()[0]
    for index, kind in enumerate(("wall", "CPU")):
        cold_s = statistics.median(run[index] for run in cli)
        warm_s = statistics.median(run[index] for run in warm)
        print(
            f"export ({kind}): hcss export (cold process) median {cold_s:.2f} s, "
            f"console zip (warm) median {warm_s:.2f} s, ratio {cold_s / warm_s:.2f} "
            f"over {RUNS} runs (load average {load:.2f})"
        )
