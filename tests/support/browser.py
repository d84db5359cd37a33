"""The browser the browser tests drive, and its fixtures (`chromium`, `browser`): a plugin of
the whole suite, so an analyst's pages are checked in it as a participant's are."""

from __future__ import annotations

import os

import pytest

# Debian's Chromium, driven by Playwright (its own browser download does not work here).
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
]


@pytest.fixture(scope="session")
def chromium():
    """One headless Chromium per test process (each xdist worker), as pytest-playwright keeps
    one per session: a launch took 2 to 2.7 s on a loaded machine, paid once, not per test."""
    if not os.path.exists(CHROMIUM):
        pytest.skip(f"browser tests need {CHROMIUM} (make browser installs it)")
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield browser
        browser.close()


@pytest.fixture
def browser(chromium):
    """The process's headless Chromium for a browser test. Each page or context the test opens
    is a context of its own (cookies, storage, cache), and all are closed after the test, so
    no test sees another's pages."""
    yield chromium
    for context in list(chromium.contexts):
        context.close()
