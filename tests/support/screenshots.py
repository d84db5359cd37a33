"""Where the browser tests put their screenshots: never into the tracked docs/ by default.

Every screenshot goes to the git-ignored test-artifacts/. The few the README
and docs show are copied over their tracked file in docs/ only when
HCSS_UPDATE_SCREENSHOTS=1 is set, so an ordinary test run leaves the working
tree clean.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
ARTIFACTS = ROOT / "test-artifacts"
DOCS = ROOT / "docs"
#: Set to 1 to refresh the screenshots in docs/.
UPDATE = "HCSS_UPDATE_SCREENSHOTS"


def screenshot(target: Any, name: str, *, docs_name: str | None = None, **options: Any) -> Path:
    """Screenshot a Playwright page or locator to test-artifacts/`name`.

    With `docs_name`, the shot is also the one docs/`docs_name` shows, and is
    copied there when HCSS_UPDATE_SCREENSHOTS=1.
    """
    ARTIFACTS.mkdir(exist_ok=True)
    path = ARTIFACTS / name
    target.screenshot(path=str(path), **options)
    if docs_name is not None and os.environ.get(UPDATE) == "1":
        shutil.copyfile(path, DOCS / docs_name)
    return path
