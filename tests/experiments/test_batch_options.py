"""Batch commands refuse absurd sizes before running anything (a clumsy or hostile caller)."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from hcss.cli import main

HUGE = str(10**12)


@pytest.mark.parametrize("command", ["experiment", "sweep", "calibrate", "fidelity"])
@pytest.mark.parametrize("option", ["--workers", "--scenarios", "--runs"])
def test_a_huge_batch_size_is_a_usage_error_and_writes_nothing(tmp_path, command, option):
    """Before: `experiment --workers 10**12` (and --scenarios, --runs) were accepted."""
    extra = ["--param", "quorum_k=10,15"] if command == "sweep" else []
    out = tmp_path / "out"
    if command in ("experiment", "sweep"):
        extra += ["--out", str(out)]
    result = CliRunner().invoke(main, ["simulate", command, *extra, option, HUGE])
    assert result.exit_code == 2, result.output
    assert f"Invalid value for '{option}'" in result.output
    assert "Traceback" not in result.output
    assert not out.exists()
