"""`hcss plan` benchmark: a power curve for N in {12, 20, 28, 40, 60} with 500 replications.

The whole command as a user runs it (its own process, 2 workers): the pool of
synthetic participants and simulation-only scenarios, `hcss analyze` of its
export, and the replications. The target is under 15 minutes on 2 idle cores.
Figures are printed, never asserted. `HCSS_PLAN_BENCH_POPULATION` names a
population.json to use (default: `hcss plan`'s, the population shipped with hcss);
`HCSS_PLAN_BENCH_OUT` keeps the plan's files there (default: a scratch directory).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_MIN = 15.0


def power_curve(replications: int = 500, workers: int = 2) -> None:
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(os.environ.get("HCSS_PLAN_BENCH_OUT") or Path(scratch) / "plan")
        command = [
            sys.executable, "-m", "hcss.cli", "plan",
            "--n", "12,20,28,40,60",
            "--replications", str(replications),
            "--workers", str(workers),
            "--out", str(out),
        ]  # fmt: skip
        population = os.environ.get("HCSS_PLAN_BENCH_POPULATION")
        if population:
            command += ["--population", population]
        started = time.perf_counter()
        subprocess.run(command, check=True, capture_output=True)
        wall = time.perf_counter() - started
        timings = json.loads((out / "plan.json").read_text(encoding="utf-8"))["timings_s"]
    parts = ", ".join(f"{k} {v / 60:.1f}" for k, v in timings.items() if k != "total")
    verdict = "within" if wall / 60 <= TARGET_MIN else "OVER"
    print(
        f"(1) hcss plan, N in 12..60, {replications} replications, {workers} workers: "
        f"{wall / 60:.1f} min wall ({parts} min), {verdict} the {TARGET_MIN:g} min target"
    )


def run(parts: list[str] | None = None) -> None:
    power_curve()
