"""An analyst's report in a real browser: `hcss analyze`'s report.html of a study export,
opened from disk as an analyst opens it, passes axe-core's WCAG 2.1 A/AA checks, and its
contents lead to every section."""

from __future__ import annotations

import pytest
from click.testing import CliRunner

from hcss.analysis.cli import analyze
from tests.support.axe import axe_violations, summary
from tests.support.synthetic import study_export

pytestmark = pytest.mark.browser


def test_a_study_report_passes_axe_and_its_contents_reach_every_section(browser, tmp_path) -> None:
    from playwright.sync_api import expect

    export = study_export(tmp_path / "export", participants=8)
    result = CliRunner().invoke(analyze, [str(export), "--out", str(tmp_path / "report")])
    assert result.exit_code == 0, result.output
    page = browser.new_page(viewport={"width": 1024, "height": 620})
    page.goto((tmp_path / "report" / "report.html").as_uri())
    violations = axe_violations(page)
    assert violations == [], summary(violations)
    links = page.locator("#contents a")
    assert links.count() > 5
    for index in range(links.count()):
        link = links.nth(index)
        anchor = link.get_attribute("href")
        link.click()
        expect(page.locator(f"{anchor} h2")).to_be_in_viewport()
    page.close()
