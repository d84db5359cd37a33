"""One writer of a trial's rows: hcss/platform/live/trial_writer.py.

Before issue 29 ten modules of the live wing wrote a trial's rows (actions,
command_keys, control, leases, orders, outages, rebuild, recorder, runner,
trials), each with its own idea of when a row may be written. Now the trial
log's rows are built and written in one module, the lease table only by the
leases (the fencing protocol) and the console's order mailbox only by the
orders. No import graph sees who writes a table, so `_all_writes` reads
the syntax trees of the whole package: a row is written where it is built
(`SimEvent(...)`, `Command.applied(...)`), inserted, updated or deleted
(`insert(Probe)`, `update(TrialOrder)`, `pg_insert(...)`), named in raw
SQL (``DELETE FROM sim_event``), changed in place after it was loaded
(`probe = session.get(Probe, i)` then `probe.truth = ...`: the session's
flush writes it), or deleted or merged through the session (in the live
wing, whatever its model). Planted writes must be found; a read must not be.
The console's withdrawal deletes every table's rows of one participant
through the table objects of the metadata (audited, under a deletion permit)
and is not a writer of a trial's log in this sense.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

from hcss.platform import models
from tests.support.source import CHECKOUT, planted

WRITER = "hcss/platform/live/trial_writer.py"
#: The facts declare their own rows (`Fact.write`), which the writer writes by.
WRITERS = {WRITER, "hcss/platform/live/facts.py"}
#: The trial log: every table of what happened in a trial, written only by the writer.
TRIAL_LOG = {
    "Trial",
    "TrialStatusChange",
    "Snapshot",
    "Interruption",
    "TrialProblem",
    "Command",
    "CommandOutcome",
    "CommandKey",
    "Observation",
    "DecisionRow",
    "SimEvent",
    "RequestStatusChange",
    "Probe",
    "ProbeEvent",
}
#: Rows about a trial that one other module owns: the lease (fencing) and the order mailbox.
OWNED = {
    "TrialLease": "hcss/platform/live/leases.py",
    "TrialOrder": "hcss/platform/live/orders.py",
}
#: The console writes its own actions on participants; in live, only the writer does.
LIVE_ONLY = {"ConsoleAction": "hcss/platform/live/"}
MODELS = TRIAL_LOG | set(OWNED) | set(LIVE_ONLY)
TABLES = {getattr(models, name).__tablename__: name for name in MODELS}
RAW_WRITE = re.compile(
    r"\b(?:INSERT\s+INTO|UPDATE|DELETE\s+FROM)\s+(" + "|".join(TABLES) + r")\b", re.IGNORECASE
)
#: Not the live code: the models' own classmethods and the schema's migrations.
SKIPPED = ("hcss/platform/models/", "hcss/platform/migrations/")


def _allowed(model: str, module: str) -> bool:
    if model not in MODELS:  # a row deleted or merged whose model the syntax does not say
        return module in WRITERS or not module.startswith("hcss/platform/live/")
    if model in OWNED:
        return module == OWNED[model]
    if model in LIVE_ONLY and not module.startswith(LIVE_ONLY[model]):
        return True
    return module in WRITERS


def _model_names(tree: ast.Module) -> dict[str, str]:
    """The local names of the models in a module (`from ... import SimEvent as E`: E)."""
    names = {name: name for name in MODELS}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            for alias in node.names:
                if alias.name in MODELS and alias.asname:
                    names[alias.asname] = alias.name
    return names


def _named_model(node: ast.expr, names: dict[str, str]) -> str | None:
    """`SimEvent`, an alias of it, or `models.SimEvent`: the model's name."""
    if isinstance(node, ast.Name):
        return names.get(node.id)
    if isinstance(node, ast.Attribute) and node.attr in MODELS:
        return node.attr
    return None


def _writes(node: ast.AST, names: dict[str, str]) -> list[tuple[str, str]]:
    """(model, how) of each write this node makes."""
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [(TABLES[m.group(1).lower()], "raw SQL") for m in RAW_WRITE.finditer(node.value)]
    if not isinstance(node, ast.Call):
        return []
    built = _named_model(node.func, names)
    if built is not None:
        return [(built, "builds")]
    if isinstance(node.func, ast.Attribute):  # Command.applied(...), CommandOutcome.of(...)
        built = _named_model(node.func.value, names)
        if built is not None and node.func.attr[0].islower():
            return [(built, f"builds with .{node.func.attr}")]
    verb = node.func.id if isinstance(node.func, ast.Name) else getattr(node.func, "attr", "")
    if (verb.endswith("insert") or verb in ("update", "delete")) and node.args:
        target = _named_model(node.args[0], names)
        if target is not None:
            return [(target, verb)]
    return []


def _loaded_rows(tree: ast.Module, names: dict[str, str]) -> dict[str, str]:
    """Local names bound to a row loaded from the database: `row = session.get(Probe, i)`,
    `row = session.scalars(select(Probe)...).one()`; name -> model."""
    loaded = {}
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Assign) and isinstance(node.value, ast.Call)):
            continue
        model = None
        for inner in ast.walk(node.value):
            if not (isinstance(inner, ast.Call) and inner.args):
                continue
            if (
                getattr(inner.func, "attr", "") in ("get", "merge")  # session.get(Probe, i)
                or getattr(inner.func, "id", "") == "select"  # select(Probe)...
            ):
                model = _named_model(inner.args[0], names)
            if model is not None:
                break
        if model is not None:
            for target in node.targets:
                if isinstance(target, ast.Name):
                    loaded[target.id] = model
    return loaded


def _row_writes(node: ast.AST, loaded: dict[str, str]) -> list[tuple[str, str]]:
    """(model, how) of a loaded row changed in place (the session flushes it as an UPDATE), or
    any row deleted or merged through the session: the writes no constructor shows."""
    targets: list[ast.expr] = []
    if isinstance(node, ast.Assign):
        targets = node.targets
    elif isinstance(node, ast.AugAssign | ast.AnnAssign):
        targets = [node.target]
    for target in targets:
        if (
            isinstance(target, ast.Attribute)
            and isinstance(target.value, ast.Name)
            and target.value.id in loaded
        ):
            return [(loaded[target.value.id], f"changes a loaded row's .{target.attr}")]
    if (
        isinstance(node, ast.Call)
        and isinstance(node.func, ast.Attribute)
        and node.func.attr in ("delete", "merge")
        and isinstance(node.func.value, ast.Name)
        and node.func.value.id == "session"
        and node.args
    ):
        arg = node.args[0]
        model = loaded.get(arg.id, "") if isinstance(arg, ast.Name) else ""
        return [(model or "a row", f"session.{node.func.attr}")]
    return []


#: (module, line, model, how)
Write = tuple[str, int, str, str]


def _all_writes(root: Path) -> list[Write]:
    """(module, line, model, how) of every write of a trial's row in the package."""
    found = []
    for path in sorted((root / "hcss").rglob("*.py")):
        module = path.relative_to(root).as_posix()
        if module.startswith(SKIPPED):
            continue
        tree = ast.parse(path.read_text())
        names = _model_names(tree)
        loaded = _loaded_rows(tree, names)
        for node in ast.walk(tree):
            for model, how in [*_writes(node, names), *_row_writes(node, loaded)]:
                found.append((module, getattr(node, "lineno", 0), model, how))
    return found


def outside_the_writer(writes: list[Write]) -> list[str]:
    """Each write by a module that does not own the row: 'module:line: how Model'."""
    return [
        f"{m}:{line}: {how} {model}" for m, line, model, how in writes if not _allowed(model, m)
    ]


def writing_modules(writes: list[Write]) -> set[str]:
    """The modules that write a trial's rows (the console's own actions left out)."""
    return {
        m
        for m, _line, model, _how in writes
        if not (model in LIVE_ONLY and not m.startswith(LIVE_ONLY[model]))
    }


def test_only_the_trial_log_writer_writes_a_trials_rows() -> None:
    writes = _all_writes(CHECKOUT)
    assert outside_the_writer(writes) == []
    assert writing_modules(writes) == {*WRITERS, *OWNED.values()}


#: (module, planted lines, what the check must say there): one copy of the source holds all.
PLANTS = [
    (  # a row built and added beside the writer
        "hcss/platform/live/runner.py",
        "def _planted(session):\n    session.add(SimEvent(trial_id=1))",
        "builds SimEvent",
    ),
    (  # through a model's own constructor
        "hcss/platform/live/commands.py",
        "def _planted(session, c, o):\n    session.add(CommandOutcome.of(c, o))",
        "builds with .of CommandOutcome",
    ),
    (  # under another name
        "hcss/platform/live/recorder.py",
        "from hcss.platform.models import ProbeEvent as Seen\n"
        "def _planted():\n    return Seen(probe_id=1, kind='ready')",
        "builds ProbeEvent",
    ),
    (  # through the models package
        "hcss/platform/console/interventions.py",
        "from hcss.platform import models\ndef _planted():\n    return models.Snapshot()",
        "builds Snapshot",
    ),
    (  # a Core statement, as the writer's own insert-if-absent is
        "hcss/platform/live/outages.py",
        "def _planted(session):\n    session.execute(pg_insert(DecisionRow).values())",
        "pg_insert DecisionRow",
    ),
    (  # an order marked done outside the order mailbox
        "hcss/platform/live/control.py",
        "def _planted(session):\n    session.execute(update(TrialOrder).values(outcome=''))",
        "update TrialOrder",
    ),
    (  # the lease, outside the leases
        "hcss/platform/live/runner.py",
        "def _planted(session):\n    session.execute(delete(TrialLease))",
        "delete TrialLease",
    ),
    (  # raw SQL
        "hcss/platform/export/__init__.py",
        "_PLANTED = 'delete from sim_event where trial_id = :t'",
        "raw SQL SimEvent",
    ),
    (  # the console's action on a trial, written by live beside the writer
        "hcss/platform/live/service.py",
        "def _planted():\n    return ConsoleAction(action='pause')",
        "builds ConsoleAction",
    ),
    (  # a participant's request written by the action, as before the facts
        "hcss/platform/live/commands.py",
        "def _planted(session, c, o):\n    session.add(Command.applied(1, c, o, step=0, sim_time=0))",
        "builds with .applied Command",
    ),
    (  # a loaded row changed in place: the session's flush writes it
        "hcss/platform/live/control.py",
        "def _planted(session):\n    trial = session.get(Trial, 1)\n    trial.duration_s = 0.0",
        "changes a loaded row's .duration_s Trial",
    ),
    (  # ... found by a query
        "hcss/platform/live/door.py",
        "def _planted(session):\n"
        "    probe = session.scalars(select(Probe).where(Probe.id == 1)).one()\n"
        "    probe.truth += 'x'",
        "changes a loaded row's .truth Probe",
    ),
    (  # a row deleted through the session, whatever its model
        "hcss/platform/live/rebuild.py",
        "def _planted(session, row):\n    session.delete(row)",
        "session.delete a row",
    ),
]


#: A read of a trial's rows (select, filter, join, a loaded row's fields), planted too: the
#: check must not cry wolf.
READ = (
    "hcss/platform/live/frames.py",
    "def _planted(session):\n"
    "    trial = session.get(Trial, 1)\n"
    "    seconds = trial.duration_s\n"
    "    return seconds, session.scalars(select(SimEvent).where(SimEvent.trial_id.in_([1])))",
)


def test_every_planted_trial_row_write_is_found_and_a_read_is_not(tmp_path: Path) -> None:
    root = planted(tmp_path, *READ)
    for module, line, _found in PLANTS:
        target = root / module
        target.write_text(target.read_text() + f"\n{line}\n")
    writes = outside_the_writer(_all_writes(root))
    missed = [
        (module, found)
        for module, _line, found in PLANTS
        if not any(w.startswith(module) and w.endswith(found) for w in writes)
    ]
    assert missed == [], writes
    assert [w for w in writes if w.startswith(READ[0])] == []
