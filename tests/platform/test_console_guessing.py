"""The console resists guessing and stale sessions.

Before: 400 wrong passwords all got a plain 401; a sign-out only deleted the
browser's cookie (a copied one kept working); cookies had no SameSite, and
no response carried a CSP, frame-ancestors or nosniff.
"""

from __future__ import annotations

from sqlalchemy import select

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.console.lockout import CLIENT_FAILURES, LOCKOUT_S
from hcss.platform.models import AuditRecord
from tests.support.console import PASSWORD, USERNAME, code_of, sign_in


def _attempt(app, username: str, password: str, address: str = "10.0.0.1"):
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = address
    return sign_in(client, username, password)


def _audits(app) -> list[AuditRecord]:
    with app.extensions["hcss_db"].session_scope() as session:
        return list(
            session.scalars(select(AuditRecord).where(AuditRecord.action == "login_lockout"))
        )


def test_repeated_wrong_passwords_lock_the_account_from_that_client_and_are_audited(
    app, experimenter
) -> None:
    from hcss.platform.console.lockout import LoginThrottle

    clock = ManualClock(1000.0)
    app.extensions["hcss_login_throttle"] = LoginThrottle(app.extensions["hcss_db"], clock)
    statuses = [_attempt(app, USERNAME, "wrong").status_code for _ in range(CLIENT_FAILURES)]
    assert statuses == [401] * CLIENT_FAILURES

    locked = _attempt(app, USERNAME, PASSWORD)  # the right password, same client
    assert locked.status_code == 429 and int(locked.headers["Retry-After"]) == LOCKOUT_S
    assert "Too many failed sign-ins" in locked.get_data(as_text=True)
    (audit,) = _audits(app)
    assert audit.experimenter == USERNAME
    assert audit.row_counts["failures"] == CLIENT_FAILURES

    clock.now += LOCKOUT_S + 1
    assert _attempt(app, USERNAME, PASSWORD).status_code == 302  # the lockout ends


def _restarted(app):
    """A new server process on the same database: nothing carried over in memory.

    Only the clock is shared, as two real processes share the wall clock.
    """
    restarted = create_app(
        {
            "DATABASE_URL": app.config["DATABASE_URL"],
            "SECRET_KEY": "test-secret",
            "TESTING": True,
            "LIVE_RUNNER": False,
        }
    )
    restarted.extensions["hcss_db"].clock = app.extensions["hcss_db"].clock
    return restarted


def test_a_restart_keeps_the_failure_counts_and_the_lockout(app, experimenter) -> None:
    """Before: the counts lived in the process, so a restart gave a guesser 5 more tries."""
    before = CLIENT_FAILURES - 2
    assert [_attempt(app, USERNAME, "wrong").status_code for _ in range(before)] == [401] * before

    restarted = _restarted(app)
    statuses = [_attempt(restarted, USERNAME, "wrong").status_code for _ in range(2)]
    assert statuses == [401, 401]  # the fifth failure, counted across the restart, locks
    assert _attempt(restarted, USERNAME, PASSWORD).status_code == 429

    again = _restarted(app)
    locked = _attempt(again, USERNAME, PASSWORD)
    assert locked.status_code == 429 and 0 < int(locked.headers["Retry-After"]) <= LOCKOUT_S
    assert [a.row_counts["failures"] for a in _audits(app)] == [CLIENT_FAILURES]
    for other in (restarted, again):
        other.extensions["hcss_db"].engine.dispose()


def test_a_correct_password_clears_the_account_count_in_the_database(app, experimenter) -> None:
    for _ in range(CLIENT_FAILURES - 1):
        assert _attempt(app, USERNAME, "wrong").status_code == 401
    assert _attempt(app, USERNAME, PASSWORD).status_code == 302
    restarted = _restarted(app)
    statuses = [_attempt(restarted, USERNAME, "wrong").status_code for _ in range(2)]
    assert statuses == [401, 401]  # counting starts again: no lockout yet
    assert _attempt(restarted, USERNAME, PASSWORD).status_code == 302
    restarted.extensions["hcss_db"].engine.dispose()


def test_sign_out_ends_the_session_on_the_server(app, console) -> None:
    cookie = console.client.get_cookie("session")
    assert cookie is not None
    assert console.get("/console/").status_code == 200
    assert console.post("/console/logout").status_code == 302

    stolen = app.test_client()
    stolen.set_cookie("session", cookie.value)  # the cookie from before the sign-out
    response = stolen.get("/console/")
    assert response.status_code == 302 and "/console/login" in response.headers["Location"]
    assert stolen.get("/console/progress.json").status_code in (302, 401)


def test_cookies_are_samesite_lax_httponly_and_secure_when_configured(app, experimenter) -> None:
    response = _attempt(app, USERNAME, PASSWORD)
    header = response.headers["Set-Cookie"]
    assert "SameSite=Lax" in header and "HttpOnly" in header and "Secure" not in header
    app.config["SESSION_COOKIE_SECURE"] = True
    assert "Secure" in _attempt(app, USERNAME, PASSWORD).headers["Set-Cookie"]


def test_cookies_are_secure_when_the_trusted_proxy_says_https(database_url) -> None:
    """Behind a TLS proxy the cookie is Secure without HCSS_SECURE_COOKIES; a forged
    X-Forwarded-Proto from a client with no proxy configured changes nothing."""
    from hcss.platform.console.accounts import create_experimenter

    for hops, secure in ((1, True), (0, False)):
        app = create_app(
            {"DATABASE_URL": database_url, "SECRET_KEY": "s", "TESTING": True, "PROXY_HOPS": hops}
        )
        app.extensions["hcss_db"].create_all()
        if hops:
            with app.extensions["hcss_db"].session_scope() as session:
                create_experimenter(session, USERNAME, PASSWORD)
        client = app.test_client()
        client.environ_base["HTTP_X_FORWARDED_PROTO"] = "https"
        headers = sign_in(client, USERNAME, PASSWORD).headers.getlist("Set-Cookie")
        (header,) = [cookie for cookie in headers if cookie.startswith("session=")]
        assert ("Secure" in header) is secure, (hops, header)
        app.extensions["hcss_runner"].stop()
        app.extensions["hcss_db"].engine.dispose()


def test_every_answer_carries_the_security_headers(app, make_trial, console) -> None:
    trial = make_trial()
    for response in (
        trial.client.get(f"/live/{trial.token}"),
        trial.client.get(f"{trial.api}/state"),
        trial.client.get("/p/not-a-token"),
        console.get("/console/"),
        app.test_client().get("/console/login"),
    ):
        csp = response.headers["Content-Security-Policy"]
        assert "frame-ancestors 'none'" in csp and "script-src 'self'" in csp
        assert "unsafe-inline" not in csp
        assert response.headers["X-Content-Type-Options"] == "nosniff"
        assert response.headers["Referrer-Policy"] == "no-referrer"


def test_pages_have_no_inline_script_or_handlers(app, make_trial, console) -> None:
    """What the CSP forbids must not be on the pages (the browser tests run them too)."""
    trial = make_trial()
    code = code_of(app, trial.token)
    for html in (
        trial.client.get(f"/live/{trial.token}").get_data(as_text=True),
        console.get("/console/").get_data(as_text=True),
        console.get(f"/console/participants/{code}").get_data(as_text=True),
        app.test_client().get("/console/login").get_data(as_text=True),
    ):
        lowered = html.lower()
        assert "<script>" not in lowered and "<style" not in lowered
        assert " onclick=" not in lowered and " onfocus=" not in lowered
        assert " style=" not in lowered
