"""Study files: the protocol as data (`<name>.toml`), read with tomllib, checked by pydantic.

A study file names the stages in order, the models, every timing and the
counterbalancing design, so a shorter demo or another design is a new file,
not new code. Everything is checked when the file is loaded, and every error
names the file, the line and the setting, so a typo fails at start-up rather
than in the middle of a participant's session.

The schema (`StudyFileSchema`) mirrors the file's tables; `Study` is what the
platform runs, with the counterbalancing design expanded into its cells.
"""

from __future__ import annotations

import hashlib
import itertools
import os
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache
from typing import Annotated, Any

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictStr,
    ValidationError,
    ValidationInfo,
    field_validator,
)

from hcss.platform.study.files import STUDIES_ENV, StudyFileError, study_text
from hcss.platform.study.limits import Timeouts
from hcss.platform.study.online import OnlineSettings
from hcss.platform.study.requirements import Requirements
from hcss.platform.study.stages import STAGES
from hcss.platform.study.toml_lines import line_of
from hcss.questionnaires.consent import consent_versions
from hcss.questionnaires.mrt import item_bank, practice_items
from hcss.questionnaires.probes import ProbeLevel
from hcss.simulation.params import MODELS
from hcss.simulation.presets import DEFAULT_PRESET, PRESETS

#: Probes per level and 20-minute trial a study may ask for (each needs a time-out apart).
MAX_PROBES_PER_LEVEL = 20

SECTIONS = ("easy", "difficult")
#: Probe answers quicker than this (ms) are flagged, unless `[probes] fast_answer_ms` says.
FAST_ANSWER_MS = 1000

__all__ = ["Cell", "MrtSettings", "Study", "StudyFileError", "load_study", "parse_study"]


@dataclass(frozen=True)
class Cell:
    """One counterbalancing cell: the order models are met and each trial's first section."""

    number: int
    model_order: tuple[str, ...]
    first_sections: dict[str, str]
    levels: dict[str, Any]


@dataclass(frozen=True)
class MrtSettings:
    practice_items: int
    part_items: tuple[int, ...]
    part_time_limit_s: float
    break_s: float


@dataclass(frozen=True)
class Study:
    name: str
    title: str
    consent_version: str
    models: tuple[str, ...]
    before: tuple[str, ...]
    per_model: tuple[str, ...]
    after: tuple[str, ...]
    training_s: float
    trial_s: float
    max_time_acceleration: float
    mrt: MrtSettings
    probe_counts: dict[int, int]
    cells: tuple[Cell, ...]
    digest: str  # sha256 of the file, stored with each enrolment
    online: OnlineSettings = OnlineSettings()  # the `[online]` table: study link, completion
    fast_answer_ms: int = FAST_ANSWER_MS  # `[probes] fast_answer_ms`: quicker answers are flagged
    requirements: Requirements = Requirements()  # the device checked before consent
    simulation_preset: str = DEFAULT_PRESET  # `[simulation] preset`: the collectives' params
    timeouts: Timeouts = Timeouts()  # `[timeouts]`: when an abandoned participant is timed out

    def cell(self, number: int) -> Cell:
        for cell in self.cells:
            if cell.number == number:
                return cell
        raise ValueError(
            f"study {self.name!r} has cells 1 to {len(self.cells)}; there is no cell {number!r}"
        )


# --- the file's schema ----------------------------------------------------------------

Positive = Annotated[float, Field(gt=0)]


class _Table(BaseModel):
    """A table of a study file: every key known, every value of its own TOML type."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class SequenceTable(_Table):
    before: list[str]
    per_model: list[str]
    after: list[str]

    @field_validator("before", "per_model", "after")
    @classmethod
    def _known_stages_in_their_part(cls, names: list[str], info: ValidationInfo) -> list[str]:
        part = info.field_name
        for stage in names:
            if stage not in STAGES:
                raise ValueError(f"unknown stage {stage!r}; known: {sorted(STAGES)}")
            if STAGES[stage].per_model != (part == "per_model"):
                where = "per_model" if STAGES[stage].per_model else "before/after"
                raise ValueError(f"stage {stage!r} belongs in sequence.{where}")
        return names


class TimingTable(_Table):
    training_s: Positive
    trial_s: Positive
    max_time_acceleration: Positive


class MrtTable(_Table):
    practice_items: int
    part_items: Annotated[list[Annotated[int, Field(gt=0)]], Field(min_length=1)]
    part_time_limit_s: Positive
    break_s: Positive

    @field_validator("practice_items")
    @classmethod
    def _within_the_practice_bank(cls, count: int) -> int:
        if not 0 <= count <= len(practice_items()):
            raise ValueError(f"must be 0 to {len(practice_items())} (the practice items there are)")
        return count

    @field_validator("part_items")
    @classmethod
    def _within_the_item_bank(cls, parts: list[int]) -> list[int]:
        if sum(parts) > len(item_bank()):
            raise ValueError(f"asks for {sum(parts)} items; the MRT bank has {len(item_bank())}")
        return parts


class ProbesTable(_Table):
    """Probes per level (`ProbeLevel`, by name) and 20-minute trial."""

    perception: int
    comprehension: int
    projection: int
    #: An answer given sooner after its question showed is flagged in the export
    #: (`probes.fast_answer`): too fast to have read the question.
    fast_answer_ms: Annotated[int, Field(ge=0, le=30_000)] = FAST_ANSWER_MS

    @field_validator("perception", "comprehension", "projection")
    @classmethod
    def _drawable(cls, count: int) -> int:
        # The live runner draws these per 20-minute trial (scaled to the trial's length).
        if not 0 <= count <= MAX_PROBES_PER_LEVEL:
            raise ValueError(
                f"must be 0 to {MAX_PROBES_PER_LEVEL}: the [probes] counts are per level"
            )
        return count


class CounterbalancingTable(_Table):
    factors: dict[str, Annotated[list[Any], Field(min_length=1)]]
    constants: dict[str, Any] = {}
    exclude: list[dict[str, Any]] = []


class SimulationTable(_Table):
    """The simulation's named parameter preset (hcss.simulation.presets)."""

    preset: StrictStr = DEFAULT_PRESET

    @field_validator("preset")
    @classmethod
    def _known_preset(cls, name: str) -> str:
        if name not in PRESETS:
            raise ValueError(f"names no preset; presets: {sorted(PRESETS)}")
        return name


class StudyFileSchema(BaseModel):
    """The whole file, table by table.

    Lax only so that `[online]` and `[requirements]` become their dataclasses; every value here
    and in the tables is still held to its own type.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: StrictStr
    title: StrictStr
    consent_version: StrictStr
    models: list[StrictStr]
    sequence: SequenceTable
    timing: TimingTable
    mrt: MrtTable
    probes: ProbesTable
    counterbalancing: CounterbalancingTable
    online: OnlineSettings = OnlineSettings()
    requirements: Requirements = Requirements()
    simulation: SimulationTable = SimulationTable()
    timeouts: Timeouts = Timeouts()

    @field_validator("models")
    @classmethod
    def _distinct_known_models(cls, models: list[str]) -> list[str]:
        if not models or any(m not in MODELS for m in models) or len(set(models)) != len(models):
            raise ValueError(f"must name distinct models of {MODELS}")
        return models

    @field_validator("consent_version")
    @classmethod
    def _consent_text_exists(cls, version: str) -> str:
        if version not in consent_versions():
            raise ValueError(f"names no consent text; have {consent_versions()}")
        return version


# --- errors that name the setting and its line ---------------------------------------

#: How a TOML type is named to the person editing the file.
_KINDS = {
    "bool_type": "a bool",
    "string_type": "a string",
    "int_type": "an integer",
    "float_type": "a number",
    "list_type": "a list",
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
    table: Any = StudyFileSchema
    for part in location:
        fields = getattr(table, "__pydantic_fields__", None)
        if fields is None or part not in fields:
            return []
        table = fields[part].annotation
    return sorted(getattr(table, "__pydantic_fields__", {}))


def _phrase(error: Any) -> str:
    """One pydantic error in the words of a study file."""
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
        key = _dotted([part for part in detail["loc"] if not isinstance(part, int)])
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
    try:
        schema = StudyFileSchema.model_validate(doc)
    except ValidationError as error:
        raise _schema_errors(error, source, text) from None
    sequence = schema.sequence
    if not (sequence.before or sequence.per_model or sequence.after) or (
        (sequence.before or sequence.per_model or sequence.after)[0] != "consent"
    ):
        raise StudyFileError(
            _located(source, text, "sequence", "the first stage of `sequence` must be consent")
        )
    models = tuple(schema.models)
    return Study(
        name=schema.name,
        title=schema.title,
        consent_version=schema.consent_version,
        models=models,
        before=tuple(sequence.before),
        per_model=tuple(sequence.per_model),
        after=tuple(sequence.after),
        training_s=schema.timing.training_s,
        trial_s=schema.timing.trial_s,
        max_time_acceleration=schema.timing.max_time_acceleration,
        mrt=MrtSettings(
            practice_items=schema.mrt.practice_items,
            part_items=tuple(schema.mrt.part_items),
            part_time_limit_s=schema.mrt.part_time_limit_s,
            break_s=schema.mrt.break_s,
        ),
        probe_counts={
            int(level): getattr(schema.probes, level.name.lower()) for level in ProbeLevel
        },
        fast_answer_ms=schema.probes.fast_answer_ms,
        cells=_cells(schema.counterbalancing, models, source, text),
        digest=digest,
        simulation_preset=schema.simulation.preset,
        online=schema.online,
        requirements=schema.requirements,
        timeouts=schema.timeouts,
    )


def _cells(
    design: CounterbalancingTable, models: tuple[str, ...], source: str, text: str | None
) -> tuple[Cell, ...]:
    names = list(design.factors)
    cells: list[Cell] = []
    for combination in itertools.product(*(design.factors[name] for name in names)):
        levels = dict(zip(names, combination, strict=True)) | dict(design.constants)
        if any(all(levels.get(k) == v for k, v in rule.items()) for rule in design.exclude):
            continue
        problem = _cell_problem(levels, models)
        if problem is not None:
            setting, message = problem
            table = "factors" if setting in design.factors else "constants"
            key = f"counterbalancing.{table}.{setting}"
            raise StudyFileError(_located(source, text, key, f"cell {len(cells) + 1}: {message}"))
        cells.append(
            Cell(
                len(cells) + 1,
                tuple(levels["model_order"]),
                {model: levels[f"first_section_{model}"] for model in models},
                levels,
            )
        )
    if not cells:
        raise StudyFileError(
            _located(source, text, "counterbalancing", "the counterbalancing design leaves no cell")
        )
    return tuple(cells)


def _cell_problem(levels: dict[str, Any], models: tuple[str, ...]) -> tuple[str, str] | None:
    """The setting a cell's levels get wrong and what is wrong with it, or None."""
    order = levels.get("model_order")
    if not isinstance(order, list) or sorted(order) != sorted(models):
        return "model_order", f"`model_order` must list each of {models} once, got {order}"
    for model in models:
        if levels.get(f"first_section_{model}") not in SECTIONS:
            return f"first_section_{model}", f"`first_section_{model}` must be one of {SECTIONS}"
    return None
