"""Study texts render their Markdown, and nothing a hostile text holds reaches the page as markup."""

from __future__ import annotations

import re

import pytest

from hcss.platform.study.markdown import render_markdown
from hcss.questionnaires import pages


def test_the_texts_markdown_renders() -> None:
    html = render_markdown(
        "## Your task\n\nYou will **supervise** *four* collectives.\n\n"
        "- first item\n  continued here\n- second\n\n3. third\n4. fourth\n"
    )
    assert "<h2>Your task</h2>" in html
    assert "<strong>supervise</strong>" in html and "<em>four</em>" in html
    assert re.search(r"<ul>\s*<li>first item\s+continued here</li>\s*<li>second</li>\s*</ul>", html)
    assert '<ol start="3">' in html and "<li>fourth</li>" in html


@pytest.mark.parametrize(
    "hostile",
    [
        "<script>alert(1)</script>",
        '<img src="x" onerror="alert(1)">',
        "[click](javascript:alert(1))",
        '[click](" onmouseover="alert(1))',
        "![x](https://evil.example/track.png)",
        "<a href='https://evil.example'>link</a>",
        "**<iframe src=//evil.example></iframe>**",
        "<div style='position:fixed;inset:0'>cover</div>",
        "&lt;script&gt;alert(1)&lt;/script&gt;",
        "<scr<script>ipt>alert(1)</script>",
        "[x]: javascript:alert(1)\n\n[x]",
        "<!-- hidden --><svg onload=alert(1)>",
    ],
)
def test_a_hostile_text_gives_no_markup_beyond_the_typographic(hostile: str) -> None:
    html = str(render_markdown(f"Before.\n\n{hostile}\n\nAfter."))
    tags = set(re.findall(r"<\s*/?\s*([a-zA-Z0-9]+)", html))
    assert tags <= {"p", "strong", "em"}, html
    assert not re.search(r"<[^>]*\s(on\w+|href|src|style)\s*=", html, re.IGNORECASE), html
    assert "Before." in html and "After." in html


def test_every_bundled_text_renders_without_losing_its_words() -> None:
    for text in (pages.debrief_text(), *pages.introduction_pages()):
        html = str(render_markdown(text.markdown))
        words = re.sub(r"<[^>]+>", " ", html)
        assert "**" not in words and "<" not in words.replace("&lt;", "")
