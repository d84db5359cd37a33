"""Consent versions, the interface introduction and the debrief."""

from __future__ import annotations

import pytest

from hcss.questionnaires import consent, pages


def test_consent_has_a_version_and_agree_decline() -> None:
    current = consent.consent_text()
    assert current.version in consent.consent_versions()
    assert "v1" in consent.consent_versions()
    assert current.title
    assert consent.DECISION.values() == ("agree", "decline")
    assert consent.validate({"decision": "agree", "version": "v1"}) == {}
    errors = consent.validate({"decision": "maybe", "version": "v0"})
    assert errors["decision"] == ["Please choose whether you agree to take part."]
    assert set(errors) == {"decision", "version"}
    with pytest.raises(LookupError, match="v0"):
        consent.consent_text("v0")


def test_a_new_consent_version_needs_no_code_change(tmp_path, monkeypatch) -> None:
    for version in ("v1", "v2", "v10"):
        (tmp_path / f"consent-{version}.md").write_text(f"# Consent {version}\n\nText.\n")
    (tmp_path / "notes.md").write_text("# Not consent\n")
    monkeypatch.setattr(pages, "text_root", lambda: tmp_path)
    assert consent.consent_versions() == ("v1", "v2", "v10")
    latest = consent.consent_text()
    assert (latest.version, latest.title) == ("v10", "Consent v10")
    assert consent.consent_text("v2").markdown.startswith("# Consent v2")


def test_introduction_walks_through_the_interface_in_about_five_minutes() -> None:
    walkthrough_pages = pages.introduction_pages()
    assert len(walkthrough_pages) >= 3
    assert [page.number for page in walkthrough_pages] == list(range(1, len(walkthrough_pages) + 1))
    assert all(page.title for page in walkthrough_pages)
    minutes = sum(page.reading_minutes() for page in walkthrough_pages)
    assert 4.0 <= minutes <= 7.0, f"{minutes:.1f} minutes of reading"
    walkthrough = " ".join(page.markdown for page in walkthrough_pages)
    for term in (
        "Collective Requests",
        "Collective Assignments",
        "System Messages",
        "**U**",
        "**F**",
        "**C**",
        "**X**",
        "Investigate",
        "Abandon",
        "Decide",
        "Commit",
        "Reset",
        "Cancel",
        "blue outline",
        "green outline",
        "Right-click a target",
        "Right-click a hub",
        "Ready",
        "30 seconds",
    ):
        assert term in walkthrough, term


def test_debrief_states_that_mrt_norms_do_not_apply() -> None:
    debrief = pages.debrief_text()
    assert debrief.title
    assert "cannot be compared with published scores" in debrief.markdown
