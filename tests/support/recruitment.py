"""The recruitment tests' helpers: a visitor's press of Start on a study link, and study files
with the demo study's `[online]` table changed."""

from __future__ import annotations

import html
import re
from pathlib import Path
from urllib.parse import urlencode

import pytest


def demo_variant(
    directory: Path, monkeypatch: pytest.MonkeyPatch, name: str, online: dict[str, str]
) -> str:
    """Write the demo study as `name`, its `[online]` keys replaced or added (TOML values)."""
    from hcss.platform.study.files import STUDIES_ENV, study_text

    lines = study_text("demo")[1].decode().replace('name = "demo"', f'name = "{name}"').split("\n")
    start = lines.index("[online]")
    end = next(i for i in range(start + 1, len(lines)) if lines[i].startswith("["))
    kept = [line for line in lines[start + 1 : end] if line.split("=")[0].strip() not in online]
    table = ["[online]", *kept[:-1], *(f"{key} = {value}" for key, value in online.items()), ""]
    text = "\n".join(lines[:start] + table + lines[end:])
    directory.mkdir(exist_ok=True)
    (directory / f"{name}.toml").write_text(text, encoding="utf-8")
    monkeypatch.setenv(STUDIES_ENV, str(directory))
    return name


#: What the first page of a laptop's browser measures and posts with Start.
LAPTOP = {"width": "1366", "height": "768", "mobile": "0", "missing": ""}


HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')


def join(client, study: str = "demo", device=LAPTOP, **params: str):
    """Open the study link; on its first page, press Start (as a laptop's browser posts it)."""
    first = client.get(f"/join/{study}?{urlencode(params)}")
    if first.status_code != 200 or 'id="join-form"' not in first.get_data(as_text=True):
        return first
    fields = dict(HIDDEN.findall(first.get_data(as_text=True)))
    return client.post(f"/join/{study}", data=fields | dict(device))


def console_outcomes(index_html: str, study: str) -> dict[str, dict[str, object]]:
    """The console's outcome table of one study link: per outcome, its code, URL and counts
    (``count``, and one per recruitment site)."""
    table = re.search(
        rf'<table class="link-outcomes" data-study="{re.escape(study)}">(.*?)</table>',
        index_html,
        re.S,
    )
    assert table, f"no outcome table for {study}"
    rows = {}
    for outcome, cells in re.findall(r'<tr data-outcome="(\w+)">(.*?)</tr>', table[1], re.S):
        code = re.search(r'<td class="code">([^<]*)</td>', cells)[1]
        url = re.search(r'<td class="url">([^<]*)</td>', cells)[1]
        by_source = {
            source: int(n) for source, n in re.findall(r'data-source="(\w+)">(\d+)<', cells)
        }
        total = int(re.search(r'class="count total">(\d+)<', cells)[1])
        rows[outcome] = {"code": code, "url": html.unescape(url), "count": total, **by_source}
    return rows
