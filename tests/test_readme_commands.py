"""Every `hcss` command the README shows names a command that exists, with options that
command takes: a renamed command or option leaves a newcomer with "No such command".
The README walk-through test runs its export and analysis commands to their end."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import click

from hcss.cli import main

README = Path(__file__).resolve().parents[1] / "README.md"
#: A code span holding an hcss command line.
COMMAND = re.compile(r"`(?:[A-Z_]+=\S+ )*(?:\.venv/bin/)?hcss( [^`]*)?`")


def _commands() -> list[list[str]]:
    """The words after `hcss` of each command the README shows ([...] brackets opened)."""
    found = []
    for match in COMMAND.finditer(README.read_text(encoding="utf-8")):
        text = (match.group(1) or "").replace("\\|", " ").replace("[", " ").replace("]", " ")
        found.append(shlex.split(text.replace("...", " ")))
    return found


def _options(command: click.Command) -> dict[str, click.Parameter]:
    return {name: param for param in command.params for name in param.opts + param.secondary_opts}


def _problems(words: list[str]) -> list[str]:
    """What in one command line does not exist: a command, or an option of the command
    it follows (`hcss --studies DIR simulate ...`: the group's option and its value)."""
    command: click.Command = main
    context = click.Context(main, info_name="hcss")
    problems = []
    value_next = False
    for word in words:
        if value_next and not word.startswith("--"):
            value_next = False
            continue
        if word.startswith("--"):
            name = word.split("=", 1)[0]
            option = _options(command).get(name)
            if option is None and name != "--help":
                problems.append(f"{command.name}: no option {name}")
            value_next = (
                option is not None and "=" not in word and not getattr(option, "is_flag", False)
            )
        elif isinstance(command, click.Group):
            sub = command.get_command(context, word)
            if sub is None:
                problems.append(f"{command.name}: no command {word!r}")
                break
            command = sub
            context = click.Context(command, info_name=word, parent=context)
    return problems


def test_every_hcss_command_in_the_readme_exists_with_its_options() -> None:
    commands = _commands()
    assert len(commands) > 20
    wrong = {" ".join(words): p for words in commands if (p := _problems(words))}
    assert not wrong, wrong
