"""The dependency rule of docs/architecture.md, checked by import-linter's contracts.

The contracts live in pyproject.toml (`[tool.importlinter]`) and `make lint`
runs them. Here the suite runs them too, on the source, and on copies of the
source with one forbidden import planted in each, which must break them: the
import forms a walk over absolute `import hcss...` statements missed (a
relative import, `from hcss import platform`), an edge between leaves, a
cycle, and a module imported by name (refused by ruff's banned-api rule,
since no import graph sees a name in a string).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

CHECKOUT = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def lint_imports(root: Path) -> subprocess.CompletedProcess[str]:
    """import-linter over the `hcss` package found in `root`, with the project's contracts."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    return subprocess.run(
        [str(BIN / "lint-imports"), "--config", str(root / "pyproject.toml"), "--no-cache"],
        cwd=root,
        env=env,
        capture_output=True,
        text=True,
        check=False,
        timeout=300,
    )


def planted(tmp_path: Path, module: str, line: str) -> Path:
    """A copy of the source with `line` appended to `module` (a path under hcss/)."""
    root = tmp_path / "source"
    shutil.copytree(CHECKOUT / "hcss", root / "hcss", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(CHECKOUT / "pyproject.toml", root / "pyproject.toml")
    target = root / module
    target.write_text(target.read_text() + f"\n{line}\n")
    return root


def test_the_source_keeps_every_contract() -> None:
    result = lint_imports(CHECKOUT)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "0 broken" in result.stdout


@pytest.mark.parametrize(
    ("module", "line", "broken"),
    [
        (  # a relative import the AST walk skipped (level > 0)
            "hcss/platform/live/trial_log.py",
            "from ..console import forms",
            "The platform's packages are layered",
        ),
        (  # `from hcss import platform` names the package in the import's names
            "hcss/simulation/params.py",
            "from hcss import platform",
            "The leaves never import the platform or the command line",
        ),
        (  # two leaves that must not know each other
            "hcss/simulation/params.py",
            "import hcss.questionnaires.consent",
            "The model and the instruments know nothing of each other",
        ),
        (  # questionnaires -> analysis, while analysis reads questionnaires: a cycle
            "hcss/questionnaires/tlx.py",
            "from hcss.analysis import measures",
            "No import cycle between the modules of any package",
        ),
        (  # the console holding a trial in memory instead of asking the live service
            "hcss/platform/console/sessions.py",
            "from hcss.platform.live.session import RunningTrial",
            "The console reaches live trials through the live service",
        ),
        (  # the study flow writing the trial log itself
            "hcss/platform/study/trial_stage.py",
            "from hcss.platform.live import trial_log",
            "The console reaches live trials through the live service",
        ),
        (  # the participant's API carrying a command out itself, past the live service
            "hcss/platform/live/api.py",
            "from hcss.platform.live import actions",
            "The console reaches live trials through the live service",
        ),
        (  # the participant's API holding the trial in memory
            "hcss/platform/live/api.py",
            "from hcss.platform.live.session import RunningTrial",
            "The console reaches live trials through the live service",
        ),
        (  # a cycle inside a package, through an import in a function
            "hcss/platform/study/stage.py",
            "def _late():\n    from hcss.platform.study import flow",
            "No import cycle between the modules of any package",
        ),
    ],
)
def test_a_planted_import_breaks_a_contract(
    tmp_path: Path, module: str, line: str, broken: str
) -> None:
    result = lint_imports(planted(tmp_path, module, line))
    assert result.returncode != 0, result.stdout
    assert f"{broken} BROKEN" in result.stdout, result.stdout


def test_a_module_imported_by_name_is_refused(tmp_path: Path) -> None:
    """No import graph sees `import_module("hcss.platform...")`; ruff's banned-api refuses it."""
    root = planted(
        tmp_path,
        "hcss/platform/live/trial_log.py",
        'import importlib\nforms = importlib.import_module("hcss.platform.console.forms")',
    )
    result = subprocess.run(
        [str(BIN / "ruff"), "check", "--config", str(root / "pyproject.toml"), "hcss"],
        cwd=root,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode != 0
    assert "TID251" in result.stdout and "trial_log.py" in result.stdout, result.stdout
