"""`hcss export` in a cold process against the console's zip in a warm server.

Both write the same tables (`write_export`); the console's zip runs in a
server whose modules and study files are already loaded, so the difference is
what a cold command pays before and beside the export itself. Figures are the
median of RUNS. The database is HCSS_EXPORT_BENCH_DB (a URL; e.g. one filled
by `hcss bots --n 34`), else 2 demo bots in a temporary SQLite file.
"""

from __future__ import annotations

import os
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


def _cold_cli(url: str, folder: Path) -> float:
    started = time.perf_counter()
    subprocess.run(
        [sys.executable, "-m", "hcss.cli", "export", str(folder / "cli"), "--replace"],
        env={**os.environ, "DATABASE_URL": url},
        check=True,
        capture_output=True,
    )
    return time.perf_counter() - started


def _warm_zip(url: str) -> tuple[float, int]:
    """The console's zip (`export_archive`) in this process, after one warm-up; (s, bytes)."""
    from hcss.platform.db import Database
    from hcss.platform.export.archive import export_archive

    database = Database(url)
    export_archive(database, "bench")
    started = time.perf_counter()
    archive, _ = export_archive(database, "bench")
    elapsed = time.perf_counter() - started
    database.engine.dispose()
    return elapsed, len(archive.getvalue())


def run() -> None:
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch)
        url = os.environ.get("HCSS_EXPORT_BENCH_DB") or _bot_database(folder)
        cli = [_cold_cli(url, folder) for _ in range(RUNS)]
        warm = [_warm_zip(url)[0] for _ in range(RUNS)]
    load = os.getloadavg()[0]
    print(
        f"export: hcss export (cold process) median {statistics.median(cli):.2f} s, "
        f"console zip (warm) median {statistics.median(warm):.2f} s, "
        f"ratio {statistics.median(cli) / statistics.median(warm):.2f} "
        f"over {RUNS} runs (load average {load:.2f})"
    )
