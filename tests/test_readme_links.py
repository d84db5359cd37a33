"""Every link of the README and docs/ to a file of the project points at a file a fresh
clone has: tracked by git, not a git-ignored output of some earlier run."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

CHECKOUT = Path(__file__).resolve().parents[1]
DOCUMENTS = [CHECKOUT / "README.md", *sorted((CHECKOUT / "docs").glob("*.md"))]
#: A Markdown link or image: [text](target) or ![alt](target).
LINK = re.compile(r"\]\(([^)\s]+)\)")


def _tracked() -> set[str]:
    if shutil.which("git") is None or not (CHECKOUT / ".git").exists():
        pytest.skip("not a git checkout")
    listed = subprocess.run(
        ["git", "ls-files", "-z"], cwd=CHECKOUT, capture_output=True, check=True
    ).stdout
    return {name for name in listed.decode().split("\0") if name}


def test_every_link_to_a_project_file_points_at_a_tracked_file() -> None:
    tracked = _tracked()
    folders = {str(Path(name).parent) for name in tracked}
    broken = []
    for document in DOCUMENTS:
        for target in LINK.findall(document.read_text(encoding="utf-8")):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue  # a web address or an anchor on the same page
            path = (document.parent / target.split("#")[0]).resolve()
            try:
                relative = str(path.relative_to(CHECKOUT))
            except ValueError:
                continue  # outside the project (../shared): not the clone's to have
            if relative not in tracked and relative not in folders:
                broken.append(f"{document.relative_to(CHECKOUT)}: {target}")
    assert broken == []
