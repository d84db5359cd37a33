"""The dependency rule of docs/architecture.md, checked on the source (an AST walk, no imports run).

Every `import hcss...` / `from hcss... import` in hcss/, including imports inside
functions, is an edge between two units: a leaf package (hcss.simulation,
hcss.questionnaires, hcss.analysis), a platform package (hcss.platform.live,
...), or a platform core module (hcss.platform.models, db, config, ...). An
edge not in ALLOWED fails the test, naming the file and line.
"""

from __future__ import annotations

import ast
from pathlib import Path

HCSS = Path(__file__).resolve().parents[1] / "hcss"

LEAVES = {"simulation", "questionnaires", "analysis"}
#: Platform modules every platform package may use: the schema, the database, settings.
CORE = {
    "models",
    "db",
    "config",
    "naming",
    "pilots",
    "session_state",
    "errors",
    "serving",
    "hardening",
}
#: What each platform package may import besides the core and the leaf packages.
PACKAGES: dict[str, set[str]] = {
    "live": set(),
    "study": {"live"},
    "replay": {"live"},
    "export": {"live", "study"},
    "console": {"live", "study", "export"},
}
#: Modules that put the platform together (the app, the CLI, bots, the test server): anything.
COMPOSITION = {"app", "cli", "__main__", "__init__", "bots", "bot_http", "localserver"}


def unit_of(module: str) -> str:
    """'hcss.platform.live.runner' -> 'platform.live'; 'hcss.simulation.engine' -> 'simulation'."""
    parts = module.split(".")[1:]
    if not parts:
        return "hcss"
    if parts[0] != "platform":
        return parts[0]
    if len(parts) == 1:
        return "platform.__init__"
    return f"platform.{parts[1]}"


def allowed(source: str, target: str) -> bool:
    if source == target or target == "hcss":
        return True
    name, target_name = source.removeprefix("platform."), target.removeprefix("platform.")
    if source in LEAVES or source == "cli":  # hcss/cli.py wires the leaf CLIs and the platform's
        return source == "cli" or target in LEAVES
    if name in COMPOSITION:
        return True
    if target in LEAVES:
        return True
    if name in CORE:
        return target_name in CORE
    if name in PACKAGES:
        return target_name in CORE or target_name in PACKAGES[name]
    return False  # a new unit: add it to the rule (and to docs/architecture.md) first


def imports_of(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(), filename=str(path))
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            continue
        found += [(node.lineno, n) for n in names if n == "hcss" or n.startswith("hcss.")]
    return found


def forbidden_edges(root: Path = HCSS) -> list[str]:
    problems = []
    for path in sorted(root.rglob("*.py")):
        module = ".".join(path.relative_to(root.parent).with_suffix("").parts)
        source = unit_of(module)
        for line, imported in imports_of(path):
            target = unit_of(imported)
            if not allowed(source, target):
                problems.append(f"{path.relative_to(root.parent)}:{line}: {source} -> {target}")
    return problems


def test_no_module_imports_across_the_dependency_rule():
    assert forbidden_edges() == []


def test_the_rule_catches_a_forbidden_edge(tmp_path):
    """The checker itself: a live module importing the console, a leaf importing the platform."""
    package = tmp_path / "hcss"
    (package / "platform" / "live").mkdir(parents=True)
    (package / "simulation").mkdir()
    (package / "platform" / "live" / "x.py").write_text(
        "def f():\n    from hcss.platform.console.sessions import ConsoleError\n"
    )
    (package / "simulation" / "y.py").write_text("import hcss.platform.models\n")
    (package / "platform" / "study").mkdir()
    (package / "platform" / "study" / "z.py").write_text("from hcss.platform.live import runner\n")
    assert forbidden_edges(package) == [
        "hcss/platform/live/x.py:2: platform.live -> platform.console",
        "hcss/simulation/y.py:1: simulation -> platform.models",
    ]


def test_the_platform_packages_form_no_cycle():
    """The allowed edges themselves are acyclic: a package never reaches back to itself."""

    def reaches(start: str, goal: str, seen: set[str]) -> bool:
        for nxt in PACKAGES[start]:
            if nxt == goal or (nxt not in seen and reaches(nxt, goal, seen | {nxt})):
                return True
        return False

    assert not any(reaches(p, p, set()) for p in PACKAGES)
