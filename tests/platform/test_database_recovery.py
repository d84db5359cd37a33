"""The server rides out a database it cannot use: 503 with Retry-After meanwhile, and
working again as soon as the database is, without a restart."""

from __future__ import annotations

import time

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from tests.support.own_disk import own_disk
from tests.support.own_postgres import own_postgres
from tests.support.recruitment import join


def _server_app(database_url: str):
    """As `hcss serve` builds it: errors are pages, not exceptions in the test."""
    app = create_app({"DATABASE_URL": database_url, "SECRET_KEY": "s", "LIVE_RUNNER": False})
    app.extensions["hcss_runner"].clock = ManualClock(1_000_000.0)
    return app


def test_a_database_read_only_across_a_start_is_used_once_it_is_writable(tmp_path) -> None:
    with own_disk(tmp_path) as disk:
        url = f"sqlite:///{disk.path / 'hcss.sqlite3'}"
        setup = _server_app(url)
        setup.extensions["hcss_db"].create_all()
        setup.extensions["hcss_db"].engine.dispose()

        disk.read_only()
        app = _server_app(url)  # the server starts on a read-only database
        client = app.test_client()
        try:
            refused = [join(client) for _ in range(3)]
            assert [r.status_code for r in refused] == [503] * 3
            assert all(r.headers.get("Retry-After") for r in refused)
            disk.writable()
            statuses = [join(client).status_code for _ in range(3)]
            assert statuses == [302, 302, 302], statuses
        finally:
            disk.writable()
            app.extensions["hcss_db"].engine.dispose()


def test_writes_after_a_read_only_window_do_not_wait_for_connections_that_never_opened(
    tmp_path,
) -> None:
    """A connection refused while the disk was read-only (its WAL pragma failed) was
    counted as an open read-only mapping and never uncounted: once writable, every new
    connection waited the full retire wait (5 s) for it, for good."""
    with own_disk(tmp_path) as disk:
        url = f"sqlite:///{disk.path / 'hcss.sqlite3'}"
        setup = _server_app(url)
        setup.extensions["hcss_db"].create_all()
        setup.extensions["hcss_db"].engine.dispose()
        app = _server_app(url)
        client = app.test_client()
        try:
            assert join(client).status_code == 302
            app.extensions["hcss_db"].engine.dispose()
            disk.read_only()
            assert [join(client).status_code for _ in range(3)] == [503] * 3
            disk.writable()
            app.extensions["hcss_db"].engine.dispose()
            started = time.perf_counter()
            statuses = [join(client).status_code for _ in range(3)]
            took = time.perf_counter() - started
            assert statuses == [302, 302, 302], statuses
            assert took < 2.0, f"three enrolments took {took:.1f} s after the disk was writable"
        finally:
            disk.writable()
            app.extensions["hcss_db"].engine.dispose()


def test_a_postgresql_outage_answers_503_with_retry_after_and_a_please_wait_page() -> None:
    with own_postgres() as server:
        app = _server_app(server.url)
        app.extensions["hcss_db"].create_all()
        client = app.test_client()
        try:
            joined = join(client)
            assert joined.status_code == 302
            link = joined.headers["Location"]
            assert client.get(link, follow_redirects=True).status_code == 200
            server.stop()
            page = client.get(link, follow_redirects=True)
            assert page.status_code == 503 and int(page.headers["Retry-After"]) > 0
            text = page.get_data(as_text=True)
            assert "please wait" in text.lower() and 'http-equiv="refresh"' in text
            assert "Traceback" not in text
            api = client.get("/api/live/" + "x" * 20 + "/trials/1/state")
            assert api.status_code == 503 and api.get_json()["error"] == "database_unavailable"
            assert api.get_json()["held_by"] == "database"  # the page says why it waits
            server.start()
            started = time.monotonic()
            while time.monotonic() - started < 10:
                page = client.get(link, follow_redirects=True)
                if page.status_code == 200:
                    break
                time.sleep(0.2)
            assert page.status_code == 200  # the same server, no restart
        finally:
            app.extensions["hcss_db"].engine.dispose()


def test_a_signed_in_console_page_answers_503_while_the_database_is_unreachable(
    tmp_path,
) -> None:
    """The please-wait page must not need the database that failed: rendering it loaded
    the signed-in experimenter (for the templates' current_user), that query failed
    again inside the error handler, and the console answered 500 (found by the
    PostgreSQL-outage fuzz)."""
    from hcss.platform.console.accounts import create_experimenter
    from tests.support.console import sign_in

    with own_disk(tmp_path) as disk:
        url = f"sqlite:///{disk.path / 'hcss.sqlite3'}"
        app = _server_app(url)
        app.extensions["hcss_db"].create_all()
        with app.extensions["hcss_db"].session_scope() as session:
            create_experimenter(session, "alice", "correct horse battery")
        client = app.test_client()
        assert sign_in(client, "alice", "correct horse battery").status_code == 302
        assert client.get("/console/").status_code == 200
        app.extensions["hcss_db"].engine.dispose()
        disk.read_only()  # no connection can be opened now
        try:
            for path in ("/console/", "/console/progress.json"):
                page = client.get(path)
                assert page.status_code == 503, (path, page.status_code)
                assert int(page.headers["Retry-After"]) > 0
                assert b"database" in page.get_data().lower()
            assert client.get("/console/no-such-page").status_code == 404  # its page, not a 500
        finally:
            disk.writable()
            app.extensions["hcss_db"].engine.dispose()
        assert client.get("/console/").status_code == 200  # still signed in
