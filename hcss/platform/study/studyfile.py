"""Reading a study file (`<name>.toml`): tomllib, then the `Study` model, errors in the file's words.

The model (hcss.platform.study.settings) says what a study file holds; here it
is read with the stage registry, and every error names the file, the line and
the setting, so a typo fails at start-up rather than in the middle of a
participant's session.
"""

from __future__ import annotations

import hashlib
import os
import tomllib
from collections.abc import Sequence
from functools import cache
from typing import Any

from pydantic import ValidationError

from hcss.platform.study.files import STUDIES_ENV, StudyFileError, study_text
from hcss.platform.study.settings import (
    FAST_ANSWER_MS,
    STAGE_KINDS,
    Cell,
    SettingError,
    Study,
)
from hcss.platform.study.stages import STAGES
from hcss.platform.study.toml_lines import line_of

__all__ = ["FAST_ANSWER_MS", "Cell", "Study", "StudyFileError", "load_study", "parse_study"]


# --- errors that name the setting and its line ---------------------------------------

#: How a TOML type is named to the person editing the file.
_KINDS = {
    "bool_type": "a bool",
    "string_type": "a string",
    "int_type": "an integer",
    "float_type": "a number",
    "list_type": "a list",
    "tuple_type": "a list",
    "dict_type": "a table",
    "model_type": "a table",
    "dataclass_type": "a table",
}


def _dotted(location: Sequence[int | str]) -> str:
    """('mrt', 'part_items', 0) -> 'mrt.part_items[0]'."""
    text = ""
    for part in location:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text


def _known_keys(location: Sequence[int | str]) -> list[str]:
    """The settings the schema allows in the table at `location` (for 'unknown setting')."""
    table: Any = Study
    for part in location:
        fields = getattr(table, "__pydantic_fields__", None)
        if fields is None or part not in fields:
            return []
        table = fields[part].annotation
    return sorted(getattr(table, "__pydantic_fields__", {}))


def _phrase(error: Any) -> str:
    """One pydantic error in the words of a study file."""
    if isinstance(error.get("ctx", {}).get("error"), SettingError):
        return str(error["ctx"]["error"].message)
    location = list(error["loc"])
    key = _dotted(location)
    kind = error["type"]
    if kind == "missing":
        return f"missing setting `{key}`"
    if kind in ("extra_forbidden", "unexpected_keyword_argument"):
        return f"unknown setting `{key}`; known: {_known_keys(location[:-1])}"
    if kind in _KINDS:
        return f"`{key}` must be {_KINDS[kind]}, not {type(error['input']).__name__}"
    message = str(error["msg"]).removeprefix("Value error, ").replace("Input should be", "must be")
    return f"`{key}` {message}" if key else message


def _located(source: str, text: str | None, key: str, phrase: str) -> str:
    line = line_of(text, key) if text is not None else None
    return f"{source}:{line}: {phrase}" if line else f"{source}: {phrase}"


def _schema_errors(error: ValidationError, source: str, text: str | None) -> StudyFileError:
    lines = []
    for detail in error.errors():
        cause = detail.get("ctx", {}).get("error")
        key = (
            cause.key
            if isinstance(cause, SettingError)
            else _dotted([part for part in detail["loc"] if not isinstance(part, int)])
        )
        lines.append(_located(source, text, key, _phrase(detail)))
    return StudyFileError("\n".join(lines))


# --- loading ---------------------------------------------------------------------------


def load_study(name: str) -> Study:
    """The study `<name>.toml`, the user's directory searched before the bundled studies."""
    return _load_study(name, os.environ.get(STUDIES_ENV, ""))


@cache
def _load_study(name: str, user_directory: str) -> Study:
    """Cached per directory because study files change only on deploy."""
    source, raw = study_text(name)
    try:
        text = raw.decode("utf-8")
        doc = tomllib.loads(text)
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as error:
        raise StudyFileError(f"{source}: {error}") from error
    return parse_study(doc, source=source, digest=hashlib.sha256(raw).hexdigest(), text=text)


def parse_study(
    doc: dict[str, Any], *, source: str, digest: str = "", text: str | None = None
) -> Study:
    """A study from a parsed file; `text`, when given, lets each error name its line."""
    kinds = {name: stage.per_model for name, stage in STAGES.items()}
    try:
        return Study.model_validate(doc, context={STAGE_KINDS: kinds, "digest": digest})
    except ValidationError as error:
        raise _schema_errors(error, source, text) from None
