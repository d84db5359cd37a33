"""The checkout's own source, and copies of it with a line planted, for the tests that check
the structure (tests/test_architecture.py, tests/platform/test_one_writer.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[2]


def planted(tmp_path: Path, module: str, line: str) -> Path:
    """A copy of the source with `line` appended to `module` (a path under hcss/)."""
    root = tmp_path / "source"
    shutil.copytree(CHECKOUT / "hcss", root / "hcss", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(CHECKOUT / "pyproject.toml", root / "pyproject.toml")
    target = root / module
    target.write_text(target.read_text() + f"\n{line}\n")
    return root
