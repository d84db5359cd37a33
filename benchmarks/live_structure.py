"""The live wing's structure in figures: `python -m benchmarks.live_structure`.

How each figure is counted (issue 41 compares them before and after):

- modules: the modules of hcss.platform.live (its ``__init__`` not counted);
- levels: the longest chain of imports between them, counted in modules, over
  grimp's graph without the imports made only for the type checker (a chain
  of n modules is n levels: a module importing no live module is level 1);
- edges: the direct imports between two live modules, on that same graph;
- RunningTrial members: the names its class defines, dunders left out;
- modules naming a command: for each participant command, the live modules
  that name it by one of the names its code goes by (`COMMAND_NAMES`: the
  value, its fact, its parser, its action, its route), counted by their
  syntax trees; the figure is the largest, i.e. the live modules that adding
  one more such command edits;
- files a click touches: the hcss source files whose code runs (a Python
  tracer's call events) while the test client POSTs one map click, with its
  Idempotency-Key, for a trial already open (SQLite in a temporary folder), the runner
  on the database's clock as served (until this branch a test's ManualClock, which
  counted hcss/platform/bots/participant.py as one more file).
"""

from __future__ import annotations

import ast
import functools
import os
import sys
import tempfile
import uuid
from pathlib import Path
from typing import Any

import grimp

LIVE = "hcss.platform.live"
ROOT = Path(__file__).resolve().parents[1]

#: The names each participant command's code goes by, before and after issue 41 (its value,
#: fact, parser, checks, action, answer and route).
COMMAND_NAMES = {
    "request": {
        "SubmitRequest",
        "CommandApplied",
        "parse_request",
        "submit_request",
        "CheckedRequest",
        "_request_applied",
        "_request_answer",
        "_request_taken",
        "_statuses_written",
    },
    "click": {
        "Observe",
        "ObservationMade",
        "parse_observation",
        "record_observation",
        "observe",
        "Click",
        "_on_the_map",
        "_observation_made",
        "_check_on_the_map",
    },
    "ready": {
        "ProbeReady",
        "ProbeReadyPressed",
        "probe_ready",
        "_ready_checked",
        "_ready_pressed",
        "_ready_taken",
    },
    "answer": {
        "ProbeAnswer",
        "ProbeAnswered",
        "parse_answer",
        "probe_answer",
        "CheckedAnswer",
        "_answer_checked",
        "_probe_answered",
        "_answer_taken",
    },
}


def live_modules(graph: Any) -> list[str]:
    return sorted(m for m in graph.modules if m.startswith(LIVE + "."))


def import_figures() -> dict[str, int]:
    graph = grimp.build_graph("hcss", exclude_type_checking_imports=True)
    modules = live_modules(graph)
    edges = {
        (a, b) for a in modules for b in graph.find_modules_directly_imported_by(a) if b in modules
    }

    @functools.cache
    def level(module: str) -> int:
        return 1 + max((level(b) for a, b in edges if a == module), default=0)

    return {
        "live modules": len(modules),
        "import levels": max(level(m) for m in modules),
        "import edges between live modules": len(edges),
    }


def running_trial_members() -> int:
    from hcss.platform.live.running_trial import RunningTrial

    return len([name for name in vars(RunningTrial) if not name.startswith("__")])


def _names_in(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            names.add(node.id)
        elif isinstance(node, ast.Attribute):
            names.add(node.attr)
        elif isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
        elif isinstance(node, ast.alias):
            names.add(node.asname or node.name.rsplit(".", 1)[-1])
    return names


def modules_per_command() -> dict[str, list[str]]:
    folder = ROOT / "hcss/platform/live"
    named = {path.stem: _names_in(path) for path in sorted(folder.glob("*.py"))}
    return {
        command: [module for module, names in named.items() if names & words]
        for command, words in COMMAND_NAMES.items()
    }


def files_a_click_touches() -> list[str]:
    from hcss.platform.app import create_app
    from hcss.platform.live.trials import start_bot_trial

    folder = tempfile.mkdtemp(prefix="hcss-structure-")
    app = create_app(
        {
            "DATABASE_URL": f"sqlite:///{folder}/hcss.db",
            "SECRET_KEY": "structure",
            "TESTING": True,
            "LIVE_RUNNER": False,
            "WTF_CSRF_ENABLED": False,
        }
    )
    app.extensions["hcss_db"].create_all()
    with app.extensions["hcss_db"].session_scope() as session:
        participant, trial = start_bot_trial(session, seed=2, duration_s=300.0)
        token, trial_id = participant.token, trial.id
    # The runner on the database's clock, as served (a test's ManualClock would count
    # hcss/platform/bots/participant.py among the files a click touches).
    app.extensions["hcss_runner"].tick()
    client = app.test_client()
    api = f"/api/live/{token}/trials/{trial_id}"
    assert client.get(api + "/state").status_code == 200  # the trial is open and held
    touched: set[str] = set()
    package = str(ROOT / "hcss") + os.sep

    def tracer(frame: Any, event: str, _arg: Any) -> None:
        if event == "call" and frame.f_code.co_filename.startswith(package):
            touched.add(os.path.relpath(frame.f_code.co_filename, ROOT))

    click = {"kind": "collective", "collective": 0, "button": "left"}
    sys.setprofile(tracer)
    try:
        answer = client.post(
            api + "/observations", json=click, headers={"Idempotency-Key": uuid.uuid4().hex}
        )
    finally:
        sys.setprofile(None)
    assert answer.status_code == 201, answer.get_data(as_text=True)
    return sorted(touched)


def main() -> None:
    for name, value in import_figures().items():
        print(f"{name}: {value}")
    print(f"RunningTrial members: {running_trial_members()}")
    per_command = modules_per_command()
    for command, modules in per_command.items():
        print(f"live modules naming the {command} command: {len(modules)} ({', '.join(modules)})")
    print(f"modules edited to add a command: {max(len(m) for m in per_command.values())}")
    touched = files_a_click_touches()
    print(f"files a click touches: {len(touched)}")
    for path in touched:
        print(f"  {path}")


if __name__ == "__main__":
    main()
