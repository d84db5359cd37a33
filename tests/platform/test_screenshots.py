"""The browser tests' screenshots leave the tracked docs/ alone unless asked to refresh them."""

from __future__ import annotations

from pathlib import Path

from tests.support import screenshots


class Page:
    """Stands in for a Playwright page: writes a fixed image."""

    def __init__(self, content: bytes) -> None:
        self.content = content

    def screenshot(self, *, path: str, **_options: object) -> None:
        Path(path).write_bytes(self.content)


def test_a_screenshot_goes_to_the_artifacts_and_to_docs_only_when_asked(
    tmp_path, monkeypatch
) -> None:
    docs = tmp_path / "docs"
    docs.mkdir()
    tracked = docs / "screenshot-x.png"
    tracked.write_bytes(b"tracked")
    monkeypatch.setattr(screenshots, "ARTIFACTS", tmp_path / "artifacts")
    monkeypatch.setattr(screenshots, "DOCS", docs)

    monkeypatch.delenv(screenshots.UPDATE, raising=False)
    shot = screenshots.screenshot(Page(b"new"), "x.png", docs_name="screenshot-x.png")
    assert shot.read_bytes() == b"new" and tracked.read_bytes() == b"tracked"

    monkeypatch.setenv(screenshots.UPDATE, "1")
    screenshots.screenshot(Page(b"newer"), "x.png", docs_name="screenshot-x.png")
    assert tracked.read_bytes() == b"newer"
    screenshots.screenshot(Page(b"other"), "y.png")  # not a docs screenshot
    assert sorted(p.name for p in docs.iterdir()) == ["screenshot-x.png"]
