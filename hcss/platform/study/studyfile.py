"""Study files: the protocol as data (`studies/<name>.toml`), read with tomllib.

A study file names the stages in order, the models, every timing and the
counterbalancing design, so a shorter demo or another design is a new file,
not new code. Everything is checked when the file is loaded, with a message
that names the file and the setting, so a typo fails at start-up rather than
in the middle of a participant's session.
"""

from __future__ import annotations

import hashlib
import itertools
import tomllib
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import Any

from hcss.platform.config import PROJECT_ROOT
from hcss.platform.study.online import OnlineSettings, parse_online
from hcss.questionnaires.consent import consent_versions
from hcss.questionnaires.mrt import item_bank, practice_items
from hcss.questionnaires.probes import ProbeLevel
from hcss.simulation.params import MODELS

#: Probes per level and 20-minute trial a study may ask for (each needs a time-out apart).
MAX_PROBES_PER_LEVEL = 20

STUDIES_DIR = PROJECT_ROOT / "studies"
SECTIONS = ("easy", "difficult")


class StudyFileError(ValueError):
    """A study file that cannot be run; the message names the file and the setting."""


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

    def cell(self, number: int) -> Cell:
        for cell in self.cells:
            if cell.number == number:
                return cell
        raise ValueError(
            f"study {self.name!r} has cells 1 to {len(self.cells)}; there is no cell {number!r}"
        )


def study_path(name: str) -> Path:
    if not name or not name.replace("-", "").replace("_", "").isalnum():
        raise StudyFileError(f"a study name is letters, digits, - and _; got {name!r}")
    return STUDIES_DIR / f"{name}.toml"


@cache
def load_study(name: str) -> Study:
    """The study `studies/<name>.toml`, checked; cached because files change only on deploy."""
    path = study_path(name)
    if not path.exists():
        available = sorted(p.stem for p in STUDIES_DIR.glob("*.toml"))
        raise StudyFileError(f"no study file {path.name}; available: {available}")
    raw = path.read_bytes()
    try:
        doc = tomllib.loads(raw.decode("utf-8"))
    except tomllib.TOMLDecodeError as error:
        raise StudyFileError(f"{path.name}: {error}") from error
    return parse_study(doc, source=path.name, digest=hashlib.sha256(raw).hexdigest())


def _get(doc: dict[str, Any], dotted: str, kind: type | tuple[type, ...], source: str) -> Any:
    node: Any = doc
    for part in dotted.split("."):
        if not isinstance(node, dict) or part not in node:
            raise StudyFileError(f"{source}: missing setting `{dotted}`")
        node = node[part]
    if isinstance(node, bool) or not isinstance(node, kind):
        raise StudyFileError(f"{source}: `{dotted}` has the wrong type ({type(node).__name__})")
    return node


def _positive(doc: dict[str, Any], dotted: str, source: str) -> float:
    value = _get(doc, dotted, (int, float), source)
    if value <= 0:
        raise StudyFileError(f"{source}: `{dotted}` must be positive, got {value}")
    return float(value)


def parse_study(doc: dict[str, Any], *, source: str, digest: str = "") -> Study:
    from hcss.platform.study.stages import STAGES

    models = tuple(_get(doc, "models", list, source))
    if not models or any(m not in MODELS for m in models) or len(set(models)) != len(models):
        raise StudyFileError(f"{source}: `models` must name distinct models of {MODELS}")
    sequence = {
        part: tuple(_get(doc, f"sequence.{part}", list, source))
        for part in ("before", "per_model", "after")
    }
    for part, names in sequence.items():
        for stage in names:
            if stage not in STAGES:
                raise StudyFileError(
                    f"{source}: unknown stage {stage!r} in sequence.{part}; known: {sorted(STAGES)}"
                )
            if STAGES[stage].per_model != (part == "per_model"):
                where = "per_model" if STAGES[stage].per_model else "before/after"
                raise StudyFileError(f"{source}: stage {stage!r} belongs in sequence.{where}")
    all_stages = sequence["before"] + sequence["per_model"] + sequence["after"]
    if not all_stages or all_stages[0] != "consent":
        raise StudyFileError(f"{source}: the first stage must be consent")
    consent_version = _get(doc, "consent_version", str, source)
    if consent_version not in consent_versions():
        raise StudyFileError(
            f"{source}: no consent text {consent_version!r}; have {consent_versions()}"
        )
    mrt = _mrt_settings(doc, source)
    probe_counts = {
        int(level): int(_get(doc, f"probes.{level.name.lower()}", int, source))
        for level in ProbeLevel
    }
    if any(n < 0 or n > MAX_PROBES_PER_LEVEL for n in probe_counts.values()):
        # The live runner draws these per 20-minute trial (scaled to the trial's length).
        raise StudyFileError(
            f"{source}: [probes] counts must be 0 to {MAX_PROBES_PER_LEVEL} per level"
        )
    return Study(
        name=_get(doc, "name", str, source),
        title=_get(doc, "title", str, source),
        consent_version=consent_version,
        models=models,
        before=sequence["before"],
        per_model=sequence["per_model"],
        after=sequence["after"],
        training_s=_positive(doc, "timing.training_s", source),
        trial_s=_positive(doc, "timing.trial_s", source),
        max_time_acceleration=_positive(doc, "timing.max_time_acceleration", source),
        mrt=mrt,
        probe_counts=probe_counts,
        cells=_cells(doc, models, source),
        digest=digest,
        online=parse_online(doc, source),
    )


def _mrt_settings(doc: dict[str, Any], source: str) -> MrtSettings:
    parts = tuple(_get(doc, "mrt.part_items", list, source))
    if not parts or any(not isinstance(n, int) or n <= 0 for n in parts):
        raise StudyFileError(f"{source}: `mrt.part_items` is a list of positive item counts")
    if sum(parts) > len(item_bank()):
        raise StudyFileError(f"{source}: the MRT bank has {len(item_bank())} items")
    practice = _get(doc, "mrt.practice_items", int, source)
    if not 0 <= practice <= len(practice_items()):
        raise StudyFileError(f"{source}: at most {len(practice_items())} practice items")
    return MrtSettings(
        practice_items=practice,
        part_items=parts,
        part_time_limit_s=_positive(doc, "mrt.part_time_limit_s", source),
        break_s=_positive(doc, "mrt.break_s", source),
    )


def _cells(doc: dict[str, Any], models: tuple[str, ...], source: str) -> tuple[Cell, ...]:
    factors: dict[str, list[Any]] = _get(doc, "counterbalancing.factors", dict, source)
    constants: dict[str, Any] = doc.get("counterbalancing", {}).get("constants", {})
    excludes: list[dict[str, Any]] = doc.get("counterbalancing", {}).get("exclude", [])
    for name, levels in factors.items():
        if not isinstance(levels, list) or not levels:
            raise StudyFileError(f"{source}: factor `{name}` needs a list of levels")
    names = list(factors)
    cells = []
    for combination in itertools.product(*(factors[name] for name in names)):
        levels = dict(zip(names, combination, strict=True)) | dict(constants)
        if any(all(levels.get(k) == v for k, v in rule.items()) for rule in excludes):
            continue
        cells.append(_cell(len(cells) + 1, levels, models, source))
    if not cells:
        raise StudyFileError(f"{source}: the counterbalancing design leaves no cell")
    return tuple(cells)


def _cell(number: int, levels: dict[str, Any], models: tuple[str, ...], source: str) -> Cell:
    order = levels.get("model_order")
    if not isinstance(order, list) or sorted(order) != sorted(models):
        raise StudyFileError(
            f"{source}: cell {number}: `model_order` must list each of {models} once, got {order}"
        )
    sections = {}
    for model in models:
        section = levels.get(f"first_section_{model}")
        if section not in SECTIONS:
            raise StudyFileError(
                f"{source}: cell {number}: `first_section_{model}` must be one of {SECTIONS}"
            )
        sections[model] = section
    return Cell(number, tuple(order), sections, levels)
