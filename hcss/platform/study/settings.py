"""The study file as one typed model: `Study` is what the file says, table by table.

A study file (`<name>.toml`) names the stages in order, the models, every
timing and the counterbalancing design. pydantic checks it when it is read,
and the platform runs the checked model itself: `study.timing.trial_s` is the
file's `[timing] trial_s`, so a setting has one name from the file to the code
and no second model copies it. What the file implies rather than says is
derived once, when it is checked: the counterbalancing cells, and the probe
counts by level.

The stage names are checked against the stage registry, which the stages'
own modules build (and they read this model), so the registry comes in as the
validation context: `studyfile.parse_study` reads a file with it and words
every error with the file's line.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Annotated, Any, TypeVar

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    PrivateAttr,
    StrictStr,
    ValidationInfo,
    field_validator,
    model_validator,
)

from hcss.platform.study.instruction_items import InstructionCheck
from hcss.platform.study.limits import Timeouts
from hcss.platform.study.online import OnlineSettings
from hcss.platform.study.requirements import Requirements
from hcss.questionnaires.consent import consent_versions
from hcss.questionnaires.mrt.items import ITEM_COUNT, PRACTICE_COUNT
from hcss.questionnaires.probes import ProbeLevel
from hcss.simulation.params import MODELS
from hcss.simulation.presets import DEFAULT_PRESET, PRESETS

#: Probes per level and 20-minute trial a study may ask for (each needs a time-out apart).
MAX_PROBES_PER_LEVEL = 20

SECTIONS = ("easy", "difficult")
#: Probe answers quicker than this (ms) are flagged, unless `[probes] fast_answer_ms` says.
FAST_ANSWER_MS = 1000

#: The validation context's key for the stage registry: stage name -> whether it is per model.
STAGE_KINDS = "stages"


class SettingError(ValueError):
    """A problem with a setting that is not where pydantic's location points (the first stage
    of a sequence, a counterbalancing cell): `key` names the setting the error is shown at."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(message)
        self.key = key
        self.message = message


def _listed(value: Any) -> Any:
    """A TOML array as a tuple (a study is shared by every request, so it holds no lists);
    anything else is left for the tuple's own type error."""
    return tuple(value) if isinstance(value, list) else value


T = TypeVar("T")
#: A TOML array of `T`, held as a tuple.
Listed = Annotated[tuple[T, ...], BeforeValidator(_listed)]

Positive = Annotated[float, Field(gt=0)]


@dataclass(frozen=True)
class Cell:
    """One counterbalancing cell: the order models are met and each trial's first section."""

    number: int
    model_order: tuple[str, ...]
    first_sections: dict[str, str]
    levels: dict[str, Any]


class _Table(BaseModel):
    """A table of a study file: every key known, every value of its own TOML type."""

    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class SequenceTable(_Table):
    before: Listed[StrictStr]
    per_model: Listed[StrictStr]
    after: Listed[StrictStr]

    @field_validator("before", "per_model", "after")
    @classmethod
    def _known_stages_in_their_part(
        cls, names: tuple[str, ...], info: ValidationInfo
    ) -> tuple[str, ...]:
        kinds: Mapping[str, bool] | None = (info.context or {}).get(STAGE_KINDS)
        if kinds is None:
            raise ValueError("is checked against the stages: read the file with parse_study")
        part = info.field_name
        for stage in names:
            if stage not in kinds:
                raise ValueError(f"unknown stage {stage!r}; known: {sorted(kinds)}")
            if kinds[stage] != (part == "per_model"):
                where = "per_model" if kinds[stage] else "before/after"
                raise ValueError(f"stage {stage!r} belongs in sequence.{where}")
        return names

    @model_validator(mode="after")
    def _consent_first(self) -> SequenceTable:
        stages = self.before or self.per_model or self.after
        if not stages or stages[0] != "consent":
            raise SettingError("sequence", "the first stage of `sequence` must be consent")
        return self


class TimingTable(_Table):
    training_s: Positive
    trial_s: Positive
    max_time_acceleration: Positive


class MrtTable(_Table):
    practice_items: int
    part_items: Listed[Annotated[int, Field(gt=0)]]
    part_time_limit_s: Positive
    break_s: Positive

    @field_validator("practice_items")
    @classmethod
    def _within_the_practice_bank(cls, count: int) -> int:
        # The bank's sizes, not the bank: building its figures took 5.6 s of `hcss export`.
        if not 0 <= count <= PRACTICE_COUNT:
            raise ValueError(f"must be 0 to {PRACTICE_COUNT} (the practice items there are)")
        return count

    @field_validator("part_items")
    @classmethod
    def _within_the_item_bank(cls, parts: tuple[int, ...]) -> tuple[int, ...]:
        # Checked here rather than by `min_length`: pydantic reports a tuple's length
        # even when its items were refused, which would add a second, wrong complaint.
        if not parts:
            raise ValueError("must list at least one part")
        if sum(parts) > ITEM_COUNT:
            raise ValueError(f"asks for {sum(parts)} items; the MRT bank has {ITEM_COUNT}")
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

    @property
    def per_level(self) -> dict[int, int]:
        """The counts by `ProbeLevel` number, as the live runner draws them."""
        return {int(level): getattr(self, level.name.lower()) for level in ProbeLevel}


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


class Study(BaseModel):
    """A study file, checked, with its counterbalancing cells and the file's digest.

    Lax only so that `[online]`, `[requirements]` and `[timeouts]` become their
    dataclasses; every value here and in the tables is still held to its own type.
    """

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: StrictStr
    title: StrictStr
    consent_version: StrictStr
    models: Listed[StrictStr]
    sequence: SequenceTable
    timing: TimingTable
    mrt: MrtTable
    probes: ProbesTable
    counterbalancing: CounterbalancingTable
    online: OnlineSettings = OnlineSettings()
    requirements: Requirements = Requirements()
    simulation: SimulationTable = SimulationTable()
    timeouts: Timeouts = Timeouts()
    #: Questions on the introduction, asked where the sequence names instruction_check.
    instruction_check: InstructionCheck | None = None

    _cells: tuple[Cell, ...] = PrivateAttr(())
    _digest: str = PrivateAttr("")

    @field_validator("models")
    @classmethod
    def _distinct_known_models(cls, models: tuple[str, ...]) -> tuple[str, ...]:
        if not models or any(m not in MODELS for m in models) or len(set(models)) != len(models):
            raise ValueError(f"must name distinct models of {MODELS}")
        return models

    @field_validator("consent_version")
    @classmethod
    def _consent_text_exists(cls, version: str) -> str:
        if version not in consent_versions():
            raise ValueError(f"names no consent text; have {consent_versions()}")
        return version

    @model_validator(mode="after")
    def _instruction_check_declared_where_asked(self) -> Study:
        """A sequence that asks the check needs its questions. A declared check the
        sequence leaves out is kept and not asked: a variant of a study that goes
        straight from consent to the debrief keeps the parent's sections."""
        asked = "instruction_check" in self.sequence.before + self.sequence.after
        if asked and self.instruction_check is None:
            raise SettingError(
                "sequence", "the sequence names instruction_check: declare [instruction_check]"
            )
        return self

    @model_validator(mode="after")
    def _expand_the_design(self, info: ValidationInfo) -> Study:
        self._cells = _cells(self.counterbalancing, self.models)
        self._digest = (info.context or {}).get("digest", "")
        return self

    @property
    def cells(self) -> tuple[Cell, ...]:
        """The counterbalancing design expanded: every combination of factor levels, with
        the constants, less the excluded ones, numbered from 1."""
        return self._cells

    @property
    def digest(self) -> str:
        """The sha256 of the file read, stored with each enrolment ("" for a file not read
        from disk)."""
        return self._digest

    def cell(self, number: int) -> Cell:
        for cell in self.cells:
            if cell.number == number:
                return cell
        raise ValueError(
            f"study {self.name!r} has cells 1 to {len(self.cells)}; there is no cell {number!r}"
        )


def _cells(design: CounterbalancingTable, models: tuple[str, ...]) -> tuple[Cell, ...]:
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
            raise SettingError(key, f"cell {len(cells) + 1}: {message}")
        cells.append(
            Cell(
                len(cells) + 1,
                tuple(levels["model_order"]),
                {model: levels[f"first_section_{model}"] for model in models},
                levels,
            )
        )
    if not cells:
        raise SettingError("counterbalancing", "the counterbalancing design leaves no cell")
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
