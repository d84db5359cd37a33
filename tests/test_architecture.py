"""The dependency rule of docs/architecture.md, checked by import-linter's contracts,
and the rule that a `RunningTrial`'s state changes only through its methods.

The contracts live in pyproject.toml (`[tool.importlinter]`) and `make lint`
runs them. Here the suite runs them too, on the source, and on copies of the
source with one forbidden import planted in each, which must break them: the
import forms a walk over absolute `import hcss...` statements missed (a
relative import, `from hcss import platform`), an edge between leaves, a
cycle, and a module imported by name (refused by ruff's banned-api rule,
since no import graph sees a name in a string).

No tool checks who writes an object's attributes, so `state_writes` reads
the live package's syntax trees: an attribute of a `RunningTrial` or of the
state classes it is made of is assigned, deleted or has its container mutated
only by that class's own methods (through `self`), and their private
attributes are touched by nothing else. Planted writes must be found. Only
hcss/platform/live is read: the contracts above keep every other package from
holding a `RunningTrial`, and elsewhere the state's plain names (`kind`,
`model`, `seed`, `lock`) are columns and fields of other objects, which may
be written.
"""

from __future__ import annotations

import ast
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from tests.support.source import CHECKOUT, planted

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
        (  # the model asking the analysis (the old `simulate experiment` summary)
            "hcss/simulation/cli.py",
            "from hcss.analysis.summary import summarise_decisions",
            "The model runs without its experiments, the analysis, optuna or dask",
        ),
        (  # the model reaching for the search library, inside a function
            "hcss/simulation/presets.py",
            "def _late():\n    import optuna",
            "The model runs without its experiments, the analysis, optuna or dask",
        ),
        (  # the model sending runs to a cluster
            "hcss/simulation/engine.py",
            "from dask.distributed import Client",
            "The model runs without its experiments, the analysis, optuna or dask",
        ),
        (  # the model using its experiments
            "hcss/simulation/scenario.py",
            "from hcss.experiments import study_targets",
            "The model runs without its experiments, the analysis, optuna or dask",
        ),
        (  # the table contracts, which every package reads, reading the model
            "hcss/tablespec/spec.py",
            "from hcss.simulation import MODELS",
            "The table contracts import nothing else of hcss",
        ),
        (  # ... or the writer
            "hcss/tablespec/dictionary.py",
            "def _late():\n    from hcss.tidy_csv import write_rows",
            "The table contracts import nothing else of hcss",
        ),
        (  # what a request meets reaching up to the server plumbing (ratelimit once did)
            "hcss/platform/guards/ratelimit.py",
            "from hcss.platform.serving.connections import PER_CLIENT",
            "The platform's packages are layered",
        ),
        (  # ... or to a live trial
            "hcss/platform/guards/clients.py",
            "def _late():\n    from hcss.platform.live import trials",
            "The platform's packages are layered",
        ),
        (  # the settings reaching the guards again (config once imported ratelimit)
            "hcss/platform/config.py",
            "def _late():\n    from hcss.platform.guards.ratelimit import enrolment_refusal",
            "The platform's packages are layered",
        ),
        (  # the app factory knowing how it is served
            "hcss/platform/app.py",
            "from hcss.platform.serving import workers",
            "The platform's packages are layered",
        ),
        (  # the server processes building the app in process
            "hcss/platform/serving/workers.py",
            "from hcss.platform.app import create_app",
            "The platform's packages are layered",
        ),
        (  # the platform driving its own bots
            "hcss/platform/cli.py",
            "from hcss.platform.bots.participant import ManualClock",
            "The platform's packages are layered",
        ),
        (  # questionnaires -> analysis, while analysis reads questionnaires: a cycle
            "hcss/questionnaires/tlx.py",
            "from hcss.analysis import measures",
            "No import cycle between the modules of any package",
        ),
        (  # the console holding a trial in memory instead of asking the live service
            "hcss/platform/console/interventions.py",
            "from hcss.platform.live.running_trial import RunningTrial",
            "The console reaches live trials through the live service",
        ),
        (  # the study flow writing the trial log itself
            "hcss/platform/study/trial_stage.py",
            "from hcss.platform.live import trial_log",
            "The console reaches live trials through the live service",
        ),
        (  # the participant's API carrying a command out itself, past the live service
            "hcss/platform/live/api.py",
            "from hcss.platform.live import unit_of_work",
            "The console reaches live trials through the live service",
        ),
        (  # the participant's API holding the trial in memory
            "hcss/platform/live/api.py",
            "from hcss.platform.live.running_trial import RunningTrial",
            "The console reaches live trials through the live service",
        ),
        (  # the API's idempotency decorator writing keys beside the actions
            "hcss/platform/live/idempotency.py",
            "from hcss.platform.live.unit_of_work import trial_unit",
            "The console reaches live trials through the live service",
        ),
        (  # a console route holding the runner, as in `runner().host(id).paused(...)`
            "hcss/platform/console/views.py",
            "from hcss.platform.live.runner import Runner",
            "Only the live service reaches into the live wing",
        ),
        (  # the study flow carrying a command out past the live service
            "hcss/platform/study/views.py",
            "def _late():\n    from hcss.platform.live import door",
            "Only the live service reaches into the live wing",
        ),
        (  # a bot writing the trial log itself
            "hcss/platform/bots/participant.py",
            "from hcss.platform.live.trial_writer import write_fact",
            "Only the live service reaches into the live wing",
        ),
        (  # the participant's API reaching past the service for the runner
            "hcss/platform/live/api.py",
            "from hcss.platform.live.runner import Runner",
            "The console reaches live trials through the live service",
        ),
        (  # a cycle inside a package, through an import in a function
            "hcss/platform/study/stage_protocol.py",
            "def _late():\n    from hcss.platform.study import flow",
            "No import cycle between the modules of any package",
        ),
        (  # a stage reaching for the flow instead of its stage context
            "hcss/platform/study/mrt_stage.py",
            "from hcss.platform.study.flow import Flow",
            "The stages know the study flow only through the stage context",
        ),
        (  # ... or the study model, which the stages read
            "hcss/platform/study/settings.py",
            "def _late():\n    from hcss.platform.study.flow import study_now",
            "The stages know the study flow only through the stage context",
        ),
    ],
)
def test_a_planted_import_breaks_a_contract(
    tmp_path: Path, module: str, line: str, broken: str
) -> None:
    result = lint_imports(planted(tmp_path, module, line))
    assert result.returncode != 0, result.stdout
    assert f"{broken} BROKEN" in result.stdout, result.stdout


#: The app extension that holds the runner: the wing's own (live.service puts it there).
RUNNER_KEY = "hcss_runner"


def runner_key_uses(root: Path) -> list[str]:
    """Each module of hcss outside the live wing that names the runner's app extension: one
    that could take the runner from `current_app.extensions` with no import a contract sees."""
    found = []
    for path in sorted((root / "hcss").rglob("*.py")):
        relative = path.relative_to(root).as_posix()
        if relative.startswith("hcss/platform/live/"):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Constant) and node.value == RUNNER_KEY:
                found.append(f"{relative}:{node.lineno}")
    return found


def test_nothing_outside_the_wing_takes_the_runner_from_the_app() -> None:
    assert runner_key_uses(CHECKOUT) == []


def test_a_planted_route_taking_the_runner_from_the_app_is_found(tmp_path: Path) -> None:
    """The route issue 41 planted, `runner().host(id).paused(...)` with the runner read from
    the app's extensions, imports nothing a contract sees: the key is found instead."""
    line = (
        "def _planted(trial_id):\n"
        "    from flask import current_app\n"
        "    current_app.extensions['hcss_runner'].host(trial_id).paused(0.0)"
    )
    root = planted(tmp_path, "hcss/platform/console/views.py", line)
    assert runner_key_uses(root) == ["hcss/platform/console/views.py:" + str(_last_line(root))]


def _last_line(root: Path) -> int:
    return len((root / "hcss/platform/console/views.py").read_text().splitlines())


def test_a_module_in_no_layer_breaks_the_layers(tmp_path: Path) -> None:
    """The layers contract is exhaustive: a module put directly in hcss/platform and in no
    layer (as ratelimit.py and connections.py were) is refused until it is placed."""
    root = planted(tmp_path, "hcss/platform/__init__.py", "")
    (root / "hcss/platform/loose.py").write_text('"""A module in no layer."""\n')
    result = lint_imports(root)
    assert result.returncode != 0, result.stdout
    assert "The platform's packages are layered BROKEN" in result.stdout, result.stdout
    assert "hcss.platform.loose" in result.stdout, result.stdout


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


def _type_checking_only(node: ast.If) -> bool:
    test = node.test
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def type_only_imports(root: Path, package: str = "hcss/platform/study") -> list[str]:
    """Imports between a package's modules made only for the type checker.

    import-linter leaves them out (`exclude_type_checking_imports`), so a
    back-import under `if TYPE_CHECKING:` would let a package be a tree at run
    time only; the study package is one for the type checker too.
    """
    dotted = package.replace("/", ".")
    found = []
    for path in sorted((root / package).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(node, ast.If) and _type_checking_only(node)):
                continue
            for inner in ast.walk(node):
                names = (
                    [inner.module or ""]
                    if isinstance(inner, ast.ImportFrom)
                    else [alias.name for alias in inner.names]
                    if isinstance(inner, ast.Import)
                    else []
                )
                found += [
                    f"{path.relative_to(root)}:{inner.lineno}: imports {name} for types only"
                    for name in names
                    if name == dotted or name.startswith(f"{dotted}.")
                ]
    return found


def test_the_study_package_is_a_tree_for_the_type_checker_too() -> None:
    assert type_only_imports(CHECKOUT) == []


def test_a_planted_type_only_back_import_is_found(tmp_path: Path) -> None:
    root = planted(
        tmp_path,
        "hcss/platform/study/trial_stage.py",
        "import typing\nif typing.TYPE_CHECKING:\n    from hcss.platform.study.flow import Flow",
    )
    found = type_only_imports(root)
    assert len(found) == 1 and "trial_stage.py" in found[0], found
    assert "imports hcss.platform.study.flow for types only" in found[0]


#: Names that import a module named at run time (or run code that may): no import graph
#: sees them, and ruff's banned-api does not resolve the bare builtins.
IMPORTING_NAMES = {"__import__", "import_module"}
RUNNING_BUILTINS = {"exec", "eval"}


def dynamic_imports(root: Path) -> list[str]:
    """Each use in hcss/ of `__import__` or `import_module` by any name (a call, an
    attribute, an alias) and each use of the builtins `exec` and `eval`."""
    found = []
    for path in sorted((root / "hcss").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Name) and node.id in IMPORTING_NAMES | RUNNING_BUILTINS:
                name = node.id
            elif isinstance(node, ast.Attribute) and node.attr in IMPORTING_NAMES:
                name = node.attr
            elif isinstance(node, ast.alias) and node.name in IMPORTING_NAMES:
                name = node.name
            else:
                continue
            found.append(f"{path.relative_to(root)}:{getattr(node, 'lineno', '?')}: {name}")
    return found


def test_no_module_is_imported_by_name() -> None:
    assert dynamic_imports(CHECKOUT) == []


@pytest.mark.parametrize(
    ("module", "line", "found"),
    [
        (  # the builtin, in a leaf: ruff and import-linter both let it pass
            "hcss/simulation/params.py",
            'db = __import__("hcss.platform.db")',
            "__import__",
        ),
        (  # the builtin through its module
            "hcss/analysis/summary.py",
            'import builtins\nforms = builtins.__import__("hcss.platform.console.forms")',
            "__import__",
        ),
        (  # an alias, called later
            "hcss/experiments/sweep.py",
            "load = __import__",
            "__import__",
        ),
        (  # importlib's function imported by name
            "hcss/questionnaires/tlx.py",
            "from importlib import import_module",
            "import_module",
        ),
        (  # an import statement run from a string
            "hcss/questionnaires/tlx.py",
            'exec("import hcss.platform")',
            "exec",
        ),
    ],
)
def test_a_planted_import_by_name_is_found(
    tmp_path: Path, module: str, line: str, found: str
) -> None:
    uses = dynamic_imports(planted(tmp_path, module, line))
    assert any(u.startswith(module) and u.endswith(f": {found}") for u in uses), uses


#: What the model must run without: it is imported by the platform's every process.
NOT_IN_THE_MODEL = ("hcss.experiments", "hcss.analysis", "optuna", "dask", "distributed", "pandas")

#: Imports every module of hcss.simulation in a fresh interpreter and prints the
#: top-level packages and hcss packages that came with them.
LOADED_BY_THE_MODEL = """
import importlib, pkgutil, sys
import hcss.simulation as model
for module in pkgutil.iter_modules(model.__path__):
    importlib.import_module("hcss.simulation." + module.name)
print(" ".join(sorted({".".join(name.split(".")[:2]) for name in sys.modules})))
"""


def test_the_model_loads_none_of_its_experiments_analysis_or_their_libraries() -> None:
    """At run time too: the contract above reads imports, this imports every model module
    (each with its module-level side effects) and looks at what came in."""
    result = subprocess.run(
        [sys.executable, "-c", LOADED_BY_THE_MODEL],
        cwd=CHECKOUT,
        capture_output=True,
        text=True,
        check=True,
        timeout=300,
    )
    loaded = set(result.stdout.split())
    assert "hcss.simulation" in loaded and "numba" in loaded, result.stdout
    assert loaded.isdisjoint(NOT_IN_THE_MODEL), sorted(loaded & set(NOT_IN_THE_MODEL))


#: Where a live trial's state is defined, and the classes that hold it.
STATE_MODULES = (
    "hcss/platform/live/running_trial.py",
    "hcss/platform/live/clock.py",
    "hcss/platform/live/progress.py",
)
STATE_CLASSES = {"RunningTrial", "TrialClock", "ProbeSchedule", "LogCursors", "LogQueue"}

#: Methods of list, set and dict that change the container.
MUTATORS = {
    "append",
    "extend",
    "insert",
    "remove",
    "pop",
    "clear",
    "add",
    "discard",
    "update",
    "sort",
    "reverse",
    "setdefault",
    "popitem",
    "difference_update",
    "intersection_update",
    "symmetric_difference_update",
    "__setitem__",
    "__delitem__",
}


def state_names(root: Path) -> set[str]:
    """Every attribute and property of the state classes: fields, `self.x = ...`, properties."""
    names: set[str] = set()
    for module in STATE_MODULES:
        tree = ast.parse((root / module).read_text())
        for cls in ast.walk(tree):
            if not (isinstance(cls, ast.ClassDef) and cls.name in STATE_CLASSES):
                continue
            for node in ast.walk(cls):
                if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
                    names.add(node.target.id)
                elif isinstance(node, ast.FunctionDef) and any(
                    isinstance(d, ast.Name) and d.id == "property" for d in node.decorator_list
                ):
                    names.add(node.name)
                elif (
                    isinstance(node, ast.Attribute)
                    and isinstance(node.ctx, ast.Store)
                    and _on_self(node)
                ):
                    names.add(node.attr)
    return names


def _on_self(node: ast.Attribute) -> bool:
    return isinstance(node.value, ast.Name) and node.value.id == "self"


def _written_attribute(target: ast.expr) -> ast.Attribute | None:
    """The attribute a target writes: `x.a`, `x.a[i]`, `x.a[i:j]`, or None."""
    while isinstance(target, ast.Subscript):
        target = target.value
    return target if isinstance(target, ast.Attribute) else None


def _sets_by_name(node: ast.AST, names: set[str]) -> bool:
    """`setattr(x, name, ...)` (or `delattr`, `object.__setattr__`) with a state name or any
    name computed at run time."""
    if not isinstance(node, ast.Call) or len(node.args) < 2:
        return False
    func = node.func
    if not (
        (isinstance(func, ast.Name) and func.id in ("setattr", "delattr"))
        or (isinstance(func, ast.Attribute) and func.attr in ("__setattr__", "__delattr__"))
    ):
        return False
    name = node.args[1]
    return not isinstance(name, ast.Constant) or name.value in names


def state_writes(root: Path) -> list[str]:
    """Each place in the live package that writes a live trial's state other than through `self`."""
    names = state_names(root)
    found = []
    for path in sorted((root / "hcss/platform/live").rglob("*.py")):
        where = path.relative_to(root)
        for node in ast.walk(ast.parse(path.read_text())):
            targets: list[ast.expr] = []
            if isinstance(node, ast.Assign | ast.Delete):
                targets = list(node.targets)
            elif isinstance(node, ast.AugAssign | ast.AnnAssign):
                targets = [node.target]
            elif (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in MUTATORS
            ):
                targets = [node.func.value]
            if _sets_by_name(node, names):
                found.append(f"{where}:{node.lineno}: sets an attribute by name")
            for target in targets:
                for item in target.elts if isinstance(target, ast.Tuple) else [target]:
                    written = _written_attribute(item)
                    if written is not None and written.attr in names and not _on_self(written):
                        found.append(f"{where}:{node.lineno}: writes .{written.attr}")
            if (
                isinstance(node, ast.Attribute)
                and node.attr.startswith("_")
                and node.attr in names
                and not _on_self(node)
            ):
                found.append(f"{where}:{node.lineno}: reaches into .{node.attr}")
    return found


def test_a_running_trial_changes_only_through_its_methods() -> None:
    assert state_writes(CHECKOUT) == []


@pytest.mark.parametrize(
    ("module", "line", "found"),
    [
        (  # a field assigned from outside (it is a read-only property now)
            "hcss/platform/live/commands.py",
            "def _planted(live):\n    live.paused_since = None",
            "writes .paused_since",
        ),
        (  # a container of the trial changed in place
            "hcss/platform/live/recorder.py",
            "def _planted(live):\n    live.messages.append({})",
            "writes .messages",
        ),
        (  # a slice of a queue deleted
            "hcss/platform/live/runner.py",
            "def _planted(live):\n    del live.unwritten_events[1:]",
            "writes .unwritten_events",
        ),
        (  # one of a tuple's targets
            "hcss/platform/live/rebuild.py",
            "def _planted(live, sim):\n    n, live.sim = 0, sim",
            "writes .sim",
        ),
        (  # a private part of the trial reached into, even to call its method
            "hcss/platform/live/outages.py",
            "def _planted(live):\n    live._clock.stood_still(1.0)",
            "reaches into ._clock",
        ),
        (  # the state class's own private field written from its owner, not itself
            "hcss/platform/live/running_trial.py",
            "def _planted(live):\n    live._probes._shown = 0",
            "writes ._shown",
        ),
        (  # an attribute set by name
            "hcss/platform/live/control.py",
            'def _planted(live):\n    setattr(live, "version", 0)',
            "sets an attribute by name",
        ),
    ],
)
def test_a_planted_state_write_is_found(tmp_path: Path, module: str, line: str, found: str) -> None:
    writes = state_writes(planted(tmp_path, module, line))
    assert any(w.startswith(module) and found in w for w in writes), writes


def test_another_objects_field_of_the_same_name_is_not_a_state_write(tmp_path: Path) -> None:
    """A study row's `kind` or `model` outside live is not the trial's (false alarms teach
    people to silence a check)."""
    root = planted(
        tmp_path, "hcss/platform/export/__init__.py", "def _planted(row):\n    row.model = 'M1'"
    )
    assert state_writes(root) == []


#: The participant's HTTP side of live: it passes plain values to the live service
#: (live/door.py, live/frames.py), which holds the trial.
API_MODULES = (
    "hcss/platform/live/api.py",
    "hcss/platform/live/idempotency.py",
    "hcss/platform/live/access.py",
    "hcss/platform/live/views.py",
)
#: What only a holder of the trial touches: its lock, its condition, its wake-up.
TRIAL_HANDLES = {"lock", "changed", "touch"}
#: The routes and their decorator open no session (access's read-only owner check does).
SESSIONLESS = {"hcss/platform/live/api.py", "hcss/platform/live/idempotency.py"}


def trial_handles(root: Path) -> list[str]:
    """Where the API modules hold a trial (its lock, `runner().get`) or open a session.

    No import graph sees these: the runner hands out a `RunningTrial` without
    its module being imported.
    """
    found = []
    for module in API_MODULES:
        for node in ast.walk(ast.parse((root / module).read_text())):
            if not isinstance(node, ast.Attribute):
                continue
            where = f"{module}:{node.lineno}"
            if node.attr in TRIAL_HANDLES:
                found.append(f"{where}: touches .{node.attr}")
            elif (
                node.attr in ("host", "loaded")
                and isinstance(node.value, ast.Call)
                and isinstance(node.value.func, ast.Name)
                and node.value.func.id == "runner"
            ):
                found.append(f"{where}: holds runner().{node.attr}")
            elif node.attr == "session_scope" and module in SESSIONLESS:
                found.append(f"{where}: opens a session")
    return found


def test_the_participants_api_holds_no_trial_lock_or_session() -> None:
    assert trial_handles(CHECKOUT) == []


@pytest.mark.parametrize(
    ("module", "line", "found"),
    [
        (  # a route taking the trial's lock itself
            "hcss/platform/live/api.py",
            "def _planted(live):\n    with live.lock:\n        pass",
            "touches .lock",
        ),
        (  # the idempotency decorator fetching the trial to wait on it
            "hcss/platform/live/idempotency.py",
            "def _planted():\n    return runner().host(1)",
            "holds runner().host",
        ),
        (  # a route opening its own session to validate
            "hcss/platform/live/api.py",
            "def _planted():\n    with database().session_scope():\n        pass",
            "opens a session",
        ),
    ],
)
def test_a_planted_trial_handle_in_the_api_is_found(
    tmp_path: Path, module: str, line: str, found: str
) -> None:
    handles = trial_handles(planted(tmp_path, module, line))
    assert any(h.startswith(module) and found in h for h in handles), handles


# --- the tests as a wing: no test module imports another --------------------------------


def _imported(node: ast.Import | ast.ImportFrom, package: list[str]) -> list[str]:
    """The dotted modules (and names, which may be modules) an import statement reaches."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names]
    base = package[: len(package) - node.level] if node.level else []
    module = ".".join([*base, *(node.module or "").split(".")]).strip(".")
    return [module, *(f"{module}.{alias.name}" for alias in node.names)]


def imports_between_test_modules(root: Path) -> list[str]:
    """Each import in a test module (test_*.py, conftest.py) of a test module or a conftest.

    A test module shares nothing but through tests/support: helpers are imported from
    there and fixtures are named, registered by tests/conftest.py (`pytest_plugins`).
    """
    found = []
    for path in sorted(root.rglob("*.py")):
        if not (path.name.startswith("test_") or path.name == "conftest.py"):
            continue
        package = list(path.relative_to(root.parent).with_suffix("").parts)
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.Import | ast.ImportFrom):
                continue
            for name in _imported(node, package):
                last = name.rsplit(".", 1)[-1]
                if name.startswith("tests.") and (last.startswith("test_") or last == "conftest"):
                    found.append(f"{path.relative_to(root.parent)}:{node.lineno} imports {name}")
    return found


def test_no_test_module_imports_another() -> None:
    assert imports_between_test_modules(CHECKOUT / "tests") == []


@pytest.mark.parametrize(
    ("module", "line"),
    [
        ("platform/test_access.py", "from tests.platform.test_requests import _in_range_target"),
        ("platform/test_access.py", "from .test_requests import _in_range_target"),
        ("platform/test_access.py", "from tests.platform import test_requests"),
        ("analysis/test_api.py", "import tests.analysis.test_cli"),
        ("simulation/test_rules.py", "from .conftest import scenario"),
        ("platform/conftest.py", "    from tests.platform.test_failover import _Console"),
    ],
)
def test_a_planted_import_between_test_modules_is_found(
    tmp_path: Path, module: str, line: str
) -> None:
    root = tmp_path / "tests"
    shutil.copytree(CHECKOUT / "tests", root, ignore=shutil.ignore_patterns("__pycache__"))
    target = root / module
    source = target.read_text(encoding="utf-8")
    if line.startswith(" "):  # inside a function, as a lazy import
        source += f"\n\ndef _planted() -> None:\n{line}\n"
    else:
        source += f"\n{line}\n"
    target.write_text(source, encoding="utf-8")
    assert [f.split(" imports ")[0].split(":")[0] for f in imports_between_test_modules(root)] == [
        f"tests/{module}"
    ]


def calls_of(root: Path, name: str) -> list[str]:
    """Each call of `name` (a bare name or an attribute) in the live package."""
    found = []
    for path in sorted((root / "hcss/platform/live").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call):
                called = node.func
                called_name = getattr(called, "id", None) or getattr(called, "attr", None)
                if called_name == name:
                    found.append(path.name)
    return found


def test_a_lost_commit_is_settled_in_one_place() -> None:
    """The trial unit of work asks whether a command's row landed; before issue 41 the
    `committing` flag and `was_stored` were written out three times (actions twice, control)."""
    assert calls_of(CHECKOUT, "was_stored") == ["unit_of_work.py"]
    assert calls_of(CHECKOUT, "kept_until_written") == [
        "hand_back.py",
        "rebuild.py",
        "unit_of_work.py",
    ]


def test_the_door_and_the_writer_dispatch_by_declaration() -> None:
    """No `isinstance` ladder over commands in the door, nor over facts in the writer: each
    participant command is a declaration in `commands.COMMANDS`, each fact writes itself."""
    for module in ("door.py", "trial_writer.py"):
        tree = ast.parse((CHECKOUT / "hcss/platform/live" / module).read_text())
        checked = [
            ast.unparse(node.args[1])
            for node in ast.walk(tree)
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "isinstance"
        ]
        # The door tells the console's `Control` from a participant's command, nothing more.
        assert set(checked) <= ({"Control"} if module == "door.py" else set()), (module, checked)


#: The runner's verbs for "stop hosting a trial", one per reason (docs/architecture.md).
STOP_HOSTING = {"forget": "end", "let_go": "hand-over", "lose": "crash"}


def registry_removals(root: Path) -> list[str]:
    """Where a trial leaves a runner's registry (`_trials` popped, deleted from or cleared)
    in a function other than the three verbs of `STOP_HOSTING`."""
    found = []

    class Removals(ast.NodeVisitor):
        def __init__(self, where: Path) -> None:
            self.where, self.functions = where, ["<module>"]

        def visit_FunctionDef(self, node: ast.FunctionDef) -> None:
            self.functions.append(node.name)
            self.generic_visit(node)
            self.functions.pop()

        def _registry(self, node: ast.expr) -> bool:
            return isinstance(node, ast.Attribute) and node.attr == "_trials"

        def _found(self, node: ast.AST) -> None:
            if self.functions[-1] not in STOP_HOSTING:
                found.append(f"{self.where}:{node.lineno}: {self.functions[-1]}")

        def visit_Delete(self, node: ast.Delete) -> None:
            if any(isinstance(t, ast.Subscript) and self._registry(t.value) for t in node.targets):
                self._found(node)
            self.generic_visit(node)

        def visit_Call(self, node: ast.Call) -> None:
            func = node.func
            if (
                isinstance(func, ast.Attribute)
                and func.attr in ("pop", "popitem", "clear")
                and self._registry(func.value)
            ):
                self._found(node)
            self.generic_visit(node)

    for path in sorted((root / "hcss/platform/live").rglob("*.py")):
        Removals(path.relative_to(root)).visit(ast.parse(path.read_text()))
    return found


def test_a_trial_stops_being_hosted_only_by_the_runners_three_verbs() -> None:
    assert registry_removals(CHECKOUT) == []


def test_a_planted_fourth_way_to_stop_hosting_is_found(tmp_path: Path) -> None:
    root = planted(
        tmp_path,
        "hcss/platform/live/runner.py",
        "def _planted(runner, trial_id):\n    runner._trials.pop(trial_id, None)",
    )
    assert [f.rsplit(": ", 1)[1] for f in registry_removals(root)] == ["_planted"]
