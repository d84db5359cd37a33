"""Versioned consent texts and the agree/decline answer.

Each version is a Markdown file `texts/consent-<version>.md`. A researcher
adds `consent-v2.md` and new participants see it; agreements already given
keep pointing at the version they saw, which is why the platform stores the
version with the decision. Versions are ordered naturally (v10 after v9).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

from hcss.questionnaires import pages
from hcss.questionnaires.definitions import Choice, ChoiceItem, ValidationErrors
from hcss.questionnaires.pages import page_title

_FILE_PATTERN = re.compile(r"^consent-(?P<version>[A-Za-z0-9._]+)\.md$")


class ConsentDecision(StrEnum):
    AGREE = "agree"
    DECLINE = "decline"


DECISION = ChoiceItem(
    key="decision",
    prompt="Do you agree to take part in this study?",
    choices=(
        Choice(ConsentDecision.AGREE.value, "I agree"),
        Choice(ConsentDecision.DECLINE.value, "I do not agree"),
    ),
)


@dataclass(frozen=True)
class ConsentText:
    version: str
    title: str
    markdown: str


def _natural_key(version: str) -> tuple[tuple[int, int | str], ...]:
    return tuple(
        (0, int(part)) if part.isdigit() else (1, part)
        for part in re.findall(r"\d+|[^\d]+", version)
    )


def consent_versions() -> tuple[str, ...]:
    """Every available version, oldest first."""
    versions = [
        match.group("version")
        for entry in pages.text_root().iterdir()
        if (match := _FILE_PATTERN.match(entry.name))
    ]
    return tuple(sorted(versions, key=_natural_key))


def consent_text(version: str | None = None) -> ConsentText:
    """The given version, or the newest one when `version` is None."""
    versions = consent_versions()
    if not versions:
        raise LookupError("no consent text found under texts/")
    chosen = versions[-1] if version is None else version
    if chosen not in versions:
        raise LookupError(f"no consent text of version {chosen!r}; available: {versions}")
    markdown = pages.read_text(f"consent-{chosen}.md")
    return ConsentText(chosen, page_title(markdown), markdown)


def validate(answers: Mapping[str, object]) -> ValidationErrors:
    """The decision must be agree or decline, and the version one that exists."""
    errors: ValidationErrors = {}
    if answers.get("decision") not in DECISION.values():
        errors["decision"] = ["Please choose whether you agree to take part."]
    if answers.get("version") not in consent_versions():
        errors["version"] = ["The consent text shown is not a known version; reload the page."]
    return errors
