"""Study files for the recruitment-platform tests: the demo study with its `[online]` table changed."""

from __future__ import annotations

from pathlib import Path

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
