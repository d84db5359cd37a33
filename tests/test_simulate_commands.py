"""`hcss simulate ...`: one command line over two groups, the model's and the experiments'.

The commands moved out of the model's package (hcss.experiments.cli), and
users' scripts and the docs use the old lines; every `hcss simulate` line the
README and the docs show must still name a command, and its options, of the
`hcss` command, and the lines without placeholders must parse as written.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import cli as experiments_cli
from hcss.simulation import cli as model_cli

CHECKOUT = Path(__file__).resolve().parents[1]
DOCUMENTS = [CHECKOUT / "README.md", *sorted((CHECKOUT / "docs").glob("*.md"))]
#: A fenced code block, and an inline code span (which may wrap across lines).
FENCE = re.compile(r"^```[^\n]*\n(.*?)^```", re.M | re.S)
SPAN = re.compile(r"(?<!`)`(hcss simulate [^`]+)`")
#: A command line in a block, up to a comment, a pipe or a redirection.
LINE = re.compile(r"hcss simulate [a-z][^#|>\n]*")
#: A synopsis's placeholders (`--workers N`, `--out DIR`, `NAME=V1,V2,...`).
PLACEHOLDER = re.compile(r"\b[A-Z][A-Z0-9_]*\b|\.\.\.")


def documented_lines() -> list[tuple[str, str]]:
    """Every `hcss simulate` line in a code block or code span of the README and docs/."""
    found = []
    for document in DOCUMENTS:
        text = document.read_text(encoding="utf-8")
        blocks = [block.replace("\\\n", " ") for block in FENCE.findall(text)]
        lines = [line for block in blocks for line in LINE.findall(block)]
        lines += SPAN.findall(FENCE.sub("", text))
        found += [(document.name, " ".join(line.split())) for line in lines]
    return found


def simulate_group() -> click.Group:
    command = main.get_command(click.Context(main), "simulate")
    assert isinstance(command, click.Group)
    return command


def test_the_docs_show_every_simulate_command() -> None:
    named = {line.split()[2] for _, line in documented_lines()}
    group = simulate_group()
    assert named == set(group.list_commands(click.Context(group))), named


@pytest.mark.parametrize(("document", "line"), documented_lines())
def test_a_documented_line_still_works(document: str, line: str) -> None:
    group = simulate_group()
    name, *args = shlex.split(line.replace("[", " ").replace("]", " "))[2:]
    with click.Context(main) as parent:
        command = group.get_command(click.Context(group, parent=parent), name)
    assert command is not None, f"{document}: no command {name!r} in `{line}`"
    known = {opt for param in command.params for opt in (*param.opts, *param.secondary_opts)}
    unknown = [a.split("=")[0] for a in args if a.startswith("--") and a.split("=")[0] not in known]
    assert not unknown, f"{document}: `{line}` names unknown options {unknown}"
    if args and not PLACEHOLDER.search(" ".join(args)):  # a bare name refers to the command
        command.make_context(name, args, parent=click.Context(group))  # parses and validates


def test_help_lists_the_models_command_apart_from_the_experiments() -> None:
    result = CliRunner().invoke(main, ["simulate", "--help"])
    assert result.exit_code == 0, result.output
    model, experiments = result.output.split("Model commands:")[1].split("Experiment commands:")
    assert re.findall(r"^  (\w+)", model, re.M) == sorted(model_cli.simulate.commands) == ["demo"]
    listed = re.findall(r"^  (\w+)", experiments, re.M)
    assert listed == sorted(experiments_cli.simulate.commands)
    assert {"experiment", "sweep", "calibrate", "fidelity", "meanfield"} <= set(listed)


def test_an_unknown_simulate_command_is_a_usage_error() -> None:
    result = CliRunner().invoke(main, ["simulate", "replay"])
    assert result.exit_code == 2
    assert "No such command 'replay'" in result.output
