"""Where study files are found: the user's directory first, then the bundled studies.

The bundled studies (`original`, `demo`) are package data, read through
`importlib.resources`, so an installed wheel finds them as a checkout does. A
lab's own studies live in a directory it names (``HCSS_STUDIES``, or
``hcss --studies DIR``), outside the installed package, and a file there
wins over a bundled one of the same name.
"""

from __future__ import annotations

import os
from importlib import resources
from importlib.resources.abc import Traversable
from pathlib import Path

#: The environment variable naming the directory of the lab's own study files.
STUDIES_ENV = "HCSS_STUDIES"
SUFFIX = ".toml"


class StudyFileError(ValueError):
    """A study file that cannot be run; the message names the file, the line and the setting."""


class NoStudyFile(StudyFileError):
    """No study file of that name (or a name no file can have): nothing to repair."""


def bundled_directory() -> Traversable:
    return resources.files("hcss.platform.study") / "bundled"


def user_directory() -> Path | None:
    """The directory named by ``HCSS_STUDIES``, or None; StudyFileError when it is missing."""
    configured = os.environ.get(STUDIES_ENV)
    if not configured:
        return None
    path = Path(configured).expanduser()
    if not path.is_dir():
        raise StudyFileError(f"{STUDIES_ENV}={configured}: no such directory")
    return path


def _directories() -> list[Traversable]:
    user = user_directory()
    return ([user] if user is not None else []) + [bundled_directory()]


def study_names() -> list[str]:
    """Every study that can be loaded, by name."""
    return sorted(
        {
            entry.name.removesuffix(SUFFIX)
            for directory in _directories()
            for entry in directory.iterdir()
            if entry.name.endswith(SUFFIX) and entry.is_file()
        }
    )


def study_text(name: str) -> tuple[str, bytes]:
    """The file name and bytes of study `name`, from the first directory that has it."""
    if not name or not name.replace("-", "").replace("_", "").isalnum():
        raise NoStudyFile(f"a study name is letters, digits, - and _; got {name!r}")
    for directory in _directories():
        entry = directory / f"{name}{SUFFIX}"
        if entry.is_file():
            return entry.name, entry.read_bytes()
    raise NoStudyFile(f"no study file {name}{SUFFIX}; available: {study_names()}")
