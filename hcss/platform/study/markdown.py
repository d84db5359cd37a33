"""The study texts' Markdown, rendered to HTML that is safe to put in a participant's page.

Researchers write consent, introduction and debrief texts as Markdown
(hcss/questionnaires/texts, and any lab's own). markdown-it-py renders
CommonMark with raw HTML turned off, so markup typed into a text is shown as
text; nh3 then keeps only the typographic tags below, so whatever a text
holds (a link, an image, an attribute) can never script, load or navigate.
"""

from __future__ import annotations

import nh3
from markdown_it import MarkdownIt
from markupsafe import Markup

#: What a study text may be made of: headings, paragraphs, lists, emphasis, quotes, code.
ALLOWED_TAGS = frozenset(
    {"h1", "h2", "h3", "h4", "h5", "h6", "p", "br", "hr", "ul", "ol", "li"}
    | {"strong", "em", "blockquote", "code", "pre"}
)
#: A numbered list that does not start at 1 keeps its number.
ALLOWED_ATTRIBUTES = {"ol": {"start"}}

_RENDERER = MarkdownIt("commonmark", {"html": False})


def render_markdown(markdown: str) -> Markup:
    """The text as sanitised HTML."""
    html = _RENDERER.render(markdown)
    return Markup(nh3.clean(html, tags=set(ALLOWED_TAGS), attributes=ALLOWED_ATTRIBUTES))
