"""Checking a study file before it is served: every problem on its own line, by file and line.

The same reading as the server's (`parse_study`), so a file that passes here loads there,
and a file that fails says where: ``FILE:LINE: unknown setting `online.x`; known: [...]``.
"""

from __future__ import annotations

import hashlib
import re
import tomllib
from pathlib import Path

from hcss.platform.study.studyfile import Study, StudyFileError, parse_study

#: tomllib's position in a syntax error: "... (at line 2, column 8)".
_AT = re.compile(r"\s*\(at line (\d+), column \d+\)$")


def study_file_problems(path: Path) -> tuple[Study | None, list[str]]:
    """The study (None when it does not load) and one line per problem in the file."""
    source = str(path)
    try:
        raw = path.read_bytes()
    except OSError as error:
        return None, [f"{source}: {error.strerror or error}"]
    try:
        text = raw.decode("utf-8")
        document = tomllib.loads(text)
    except UnicodeDecodeError as error:
        return None, [f"{source}: not UTF-8 text ({error.reason} at byte {error.start})"]
    except tomllib.TOMLDecodeError as error:
        message = str(error)
        at = _AT.search(message)
        line = f"{source}:{at[1]}" if at else source
        return None, [f"{line}: {_AT.sub('', message)}"]
    try:
        study = parse_study(
            document, source=source, digest=hashlib.sha256(raw).hexdigest(), text=text
        )
    except StudyFileError as error:
        return None, str(error).splitlines()
    return study, []
