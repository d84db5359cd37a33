"""A signed-in experimenter enrols a second factor from the console, in Chromium.

The console's page shows a QR code (segno) and the key beside it; the test
types the key into pyotp, as an authenticator app would read it, mistypes a
code once, confirms with the right one, and is shown ten recovery codes, once.
Signed out, the password alone no longer signs in; the password with the app's
next code does, and so does the password with a recovery code.
"""

from __future__ import annotations

import re
import time

import pyotp
import pytest

from tests.support.axe import axe_violations, summary
from tests.support.console import PASSWORD, USERNAME, sign_in_page

pytestmark = pytest.mark.browser


def sign_in(page, base: str, code: str = ""):
    page.goto(f"{base}/console/login")
    page.fill("#username", USERNAME)
    page.fill("#password", PASSWORD)
    page.fill("#code", code)
    page.click("button[type=submit]")


def sign_out(page) -> None:
    from playwright.sync_api import expect

    page.get_by_role("button", name="Sign out").click()
    expect(page.locator("h1")).to_have_text("Experimenter sign-in")


def test_enrol_a_second_factor_in_the_console_then_sign_in_with_its_code(
    browser, console_app
) -> None:
    from playwright.sync_api import expect

    _, base = console_app
    page = browser.new_page(viewport={"width": 1024, "height": 620})
    sign_in_page(page, base)
    other = browser.new_context().new_page()  # the same account signed in elsewhere
    sign_in_page(other, base)

    page.click("#second-factor-link")
    expect(page.locator("h1")).to_have_text("Second factor")
    expect(page.locator("main")).to_contain_text("signs in with its password alone")
    expect(page.locator("figure.qr svg path")).to_have_count(1)
    expect(page.get_by_role("img", name=re.compile("QR code of the second factor"))).to_be_visible()
    assert axe_violations(page) == [], summary(axe_violations(page))
    secret = page.locator("#factor-secret").inner_text()
    totp = pyotp.TOTP(secret)

    # A wrong code: told so, the same key offered again, nothing changed.
    wrong = "000000" if totp.now() != "000000" else "111111"
    page.fill("#factor-code", wrong)
    page.get_by_role("button", name="Confirm").click()
    expect(page.locator("#factor-error")).to_contain_text("not the code the app shows")
    expect(page.locator("#factor-secret")).to_have_text(secret)
    assert axe_violations(page) == [], summary(axe_violations(page))

    # The right code: ten recovery codes, shown on this page only.
    page.fill("#factor-code", totp.now())
    page.get_by_role("button", name="Confirm").click()
    expect(page.locator("h1")).to_have_text("Second factor set up")
    codes = page.locator("#recovery-codes li").all_inner_texts()
    assert len(codes) == 10 and len(set(codes)) == 10
    assert all(re.fullmatch(r"[0-9a-f]{5}-[0-9a-f]{5}", code) for code in codes), codes
    assert axe_violations(page) == [], summary(axe_violations(page))

    # This browser is still signed in; the other session has ended; the codes are gone.
    page.click("#second-factor-link")
    expect(page.locator("main")).to_contain_text("Your account has a second factor")
    expect(page.locator("#recovery-codes")).to_have_count(0)
    assert codes[0] not in page.content()
    other.goto(f"{base}/console/")
    expect(other.locator("h1")).to_have_text("Experimenter sign-in")

    # Signed out: the password alone is refused; with the app's next code it signs in.
    sign_out(page)
    sign_in(page, base)
    expect(page.locator("h1")).to_have_text("Experimenter sign-in")
    sign_in(page, base, totp.at(time.time() + totp.interval))
    expect(page.locator("h1")).to_have_text("Participants")
    # And a recovery code, once.
    sign_out(page)
    sign_in(page, base, codes[3])
    expect(page.locator("h1")).to_have_text("Participants")
    sign_out(page)
    sign_in(page, base, codes[3])
    expect(page.locator("h1")).to_have_text("Experimenter sign-in")
    page.close()


def test_an_offered_key_is_not_kept_until_a_code_confirms_it(browser, console_app) -> None:
    """Leaving the page half done, or posting another account's signed offer, changes nothing."""
    from playwright.sync_api import expect

    app, base = console_app
    page = browser.new_page(viewport={"width": 1024, "height": 620})
    sign_in_page(page, base)
    page.click("#second-factor-link")
    secret = page.locator("#factor-secret").inner_text()
    page.goto(f"{base}/console/")  # left without confirming
    sign_out(page)
    sign_in(page, base)  # the password alone still signs in
    expect(page.locator("h1")).to_have_text("Participants")

    # A tampered offer is refused as too old, and a new key is offered.
    page.click("#second-factor-link")
    # the new page's offer, not the old page's none: a click returns before the page it opens
    expect(page.locator("input[name=offer]")).to_be_attached()
    page.evaluate("() => { document.querySelector('input[name=offer]').value = 'forged.value'; }")
    page.fill("#factor-code", pyotp.TOTP(secret).now())
    page.get_by_role("button", name="Confirm").click()
    expect(page.locator("#factor-error")).to_contain_text("too old")
    expect(page.locator("#factor-secret")).not_to_have_text(secret)
    with app.app_context():
        from sqlalchemy import select

        from hcss.platform.models import Experimenter

        with app.extensions["hcss_db"].session_scope() as session:
            stored = session.scalars(select(Experimenter.totp_secret)).all()
    assert stored == [None]
    page.close()
