"""`hcss --version` answers without importing the heavy libraries (numba, pandas, scipy,
SQLAlchemy): a command's module is imported when that command runs (`--help` lists them
all, so it imports them)."""

from __future__ import annotations

import subprocess
import sys

HEAVY = ("numba", "pandas", "scipy", "sqlalchemy", "flask", "matplotlib")


def _imported(*arguments: str) -> set[str]:
    """Modules `hcss ARGUMENTS` imports, from Python's own import log."""
    run = subprocess.run(
        [sys.executable, "-X", "importtime", "-c", "from hcss.cli import main; main()", *arguments],
        capture_output=True,
        text=True,
        check=False,
    )
    assert run.returncode == 0, run.stderr[-2000:]
    names = set()
    for line in run.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            names.add(line.rsplit("|", 1)[-1].strip())
    return names


def test_the_version_comes_without_the_heavy_libraries() -> None:
    imported = _imported("--version")
    packages = {name.split(".")[0] for name in imported}
    assert "hcss.cli" in imported
    assert packages.isdisjoint(HEAVY), sorted(packages & set(HEAVY))
