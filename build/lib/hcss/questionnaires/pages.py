"""Study texts kept as Markdown files under `texts/`, so researchers edit prose, not code.

The introduction is a folder of numbered pages (`introduction/01-*.md`, ...);
each page's first `#` heading is its title. Adding, removing or reordering
pages needs no code change.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import cache
from importlib import resources
from importlib.abc import Traversable

#: Typical reading speed for instructional text, used to budget reading time.
READING_WORDS_PER_MINUTE = 250


def text_root() -> Traversable:
    return resources.files("hcss.questionnaires").joinpath("texts")


def read_text(name: str) -> str:
    """A text file under `texts/`, e.g. "debrief.md"."""
    return text_root().joinpath(name).read_text(encoding="utf-8")


@dataclass(frozen=True)
class TextPage:
    number: int
    title: str
    markdown: str

    def word_count(self) -> int:
        return len(re.findall(r"[A-Za-z0-9][A-Za-z0-9'’-]*", self.markdown))

    def reading_minutes(self) -> float:
        return self.word_count() / READING_WORDS_PER_MINUTE


def page_title(markdown: str) -> str:
    for line in markdown.splitlines():
        if line.startswith("# "):
            return line[2:].strip()
    raise ValueError("a page needs a '# ' heading for its title")


@cache
def introduction_pages() -> tuple[TextPage, ...]:
    """The interface walk-through, page by page in file-name order.

    Read once per process, like the study files (texts change only on deploy):
    the study flow asks for the pages' count on every page load.
    """
    folder = text_root().joinpath("introduction")
    names = sorted(entry.name for entry in folder.iterdir() if entry.name.endswith(".md"))
    pages = []
    for number, name in enumerate(names, start=1):
        markdown = folder.joinpath(name).read_text(encoding="utf-8")
        pages.append(TextPage(number, page_title(markdown), markdown))
    return tuple(pages)


def debrief_text() -> TextPage:
    markdown = read_text("debrief.md")
    return TextPage(1, page_title(markdown), markdown)
