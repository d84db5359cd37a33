"""The small Markdown subset the study texts use, rendered to safe HTML.

Researchers write consent, introduction and debrief texts as Markdown
(hcss/questionnaires/texts). They use headings, paragraphs, bulleted and
numbered lists (with indented continuation lines), **bold** and *italic*;
that is all this renders. Text is escaped first, so a text file can never
inject markup into a participant's page.
"""

from __future__ import annotations

import re

from markupsafe import Markup, escape

_BULLET = re.compile(r"^[-*] +(.*)$")
_NUMBERED = re.compile(r"^\d+\. +(.*)$")
_HEADING = re.compile(r"^(#{1,6}) +(.*)$")


def _inline(text: str) -> str:
    html = str(escape(text))
    html = re.sub(r"\*\*(.+?)\*\*", r"<strong>\1</strong>", html)
    return re.sub(r"(?<![*\w])\*(?!\s)(.+?)(?<!\s)\*(?!\*)", r"<em>\1</em>", html)


def render_markdown(markdown: str) -> Markup:
    """HTML for the texts' Markdown subset; unknown syntax is shown as plain text."""
    out: list[str] = []
    paragraph: list[str] = []
    items: list[list[str]] = []
    list_tag = ""

    def flush_paragraph() -> None:
        if paragraph:
            out.append(f"<p>{_inline(' '.join(paragraph))}</p>")
            paragraph.clear()

    def flush_list() -> None:
        nonlocal list_tag
        if items:
            body = "".join(f"<li>{_inline(' '.join(item))}</li>" for item in items)
            out.append(f"<{list_tag}>{body}</{list_tag}>")
            items.clear()
        list_tag = ""

    for raw in markdown.splitlines():
        line = raw.rstrip()
        stripped = line.strip()
        heading = _HEADING.match(line)
        bullet, numbered = _BULLET.match(line), _NUMBERED.match(line)
        if not stripped:
            flush_paragraph()
            flush_list()
        elif heading:
            flush_paragraph()
            flush_list()
            level = len(heading.group(1))
            out.append(f"<h{level}>{_inline(heading.group(2))}</h{level}>")
        elif bullet or numbered:
            flush_paragraph()
            tag = "ul" if bullet else "ol"
            if list_tag and list_tag != tag:
                flush_list()
            list_tag = tag
            items.append([(bullet or numbered).group(1)])  # type: ignore[union-attr]
        elif items and line.startswith(" "):
            items[-1].append(stripped)  # continuation of the list item
        else:
            flush_list()
            paragraph.append(stripped)
    flush_paragraph()
    flush_list()
    return Markup("\n".join(out))
