"""Which line of a TOML text sets a key, so a study-file error can point at it.

tomllib returns values without positions, and no maintained TOML reader
reports them; a study file is short and flat (tables, keys, dotted keys), so
one pass over its lines finds where each key is set.
"""

from __future__ import annotations

import re

_HEADER = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?\s*(#.*)?$")
_KEY = re.compile(
    r"""^\s*((?:[A-Za-z0-9_-]+|"[^"]*"|'[^']*')(?:\s*\.\s*(?:[A-Za-z0-9_-]+|"[^"]*"|'[^']*'))*)\s*="""
)


def _parts(key: str) -> list[str]:
    return [
        part.strip().strip("\"'")
        for part in re.split(r"\.(?=(?:[^\"']|\"[^\"]*\"|'[^']*')*$)", key)
    ]


def line_of(text: str, dotted: str) -> int | None:
    """The 1-based line setting `dotted` ("timing.trial_s"), else its nearest enclosing table's.

    None when the text sets neither (the key is missing and so is its table).
    """
    wanted = dotted.split(".")
    found, depth = None, 0
    table: list[str] = []
    for number, line in enumerate(text.splitlines(), 1):
        if header := _HEADER.match(line):
            table = _parts(header[1])
            key = table
        elif assignment := _KEY.match(line):
            key = table + _parts(assignment[1])
        else:
            continue
        shared = len(key) if key == wanted[: len(key)] else 0
        if shared > depth:
            found, depth = number, shared
    return found
