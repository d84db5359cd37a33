"""Render the first screen of report.html to docs/screenshot-report.png (README image).

Usage: .venv/bin/python scripts/report_screenshot.py REPORT_DIR
(REPORT_DIR from `hcss analyze ... --out REPORT_DIR`). Drives the system
Chromium through Playwright, headless, with the project's usual flags.
"""

from __future__ import annotations

import sys
from pathlib import Path

from playwright.sync_api import sync_playwright

CHROMIUM = "/usr/bin/chromium"
FLAGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


def main(report: Path, out: Path = Path("docs/screenshot-report.png")) -> None:
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        page = browser.new_page(viewport={"width": 1280, "height": 900})
        page.goto((report / "report.html").resolve().as_uri())
        page.screenshot(path=str(out))
        browser.close()
    print(f"wrote {out}")


if __name__ == "__main__":
    main(Path(sys.argv[1]))
