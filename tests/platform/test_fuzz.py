"""Property-based fuzzing of every route (issue 13 §2): no input gives a 5xx or a traceback.

Hypothesis draws a route and fills its path, query, headers and body with
what a hostile or clumsy client sends: the real token, trial and codes (so
the request gets past the first check) mixed with huge and negative ids, NUL
bytes, superscript digits, 5,000-digit numbers, JSON nested thousands deep,
wrong types and random text. CSRF is off here (it is tested on its own in
test_console_access and test_access) so the fuzz reaches the code behind it.

Beyond the three route groups: Host headers that are no hostname and hostile
multipart names on every group; every console page after failed sign-ins
from several clients with the lockout on; and every group while the disk
under SQLite is full, or while PostgreSQL comes and goes (its line cut by a
proxy of the test's own, never the shared server stopped), with the runner
ticking: a 503 with Retry-After that says the database is away is the right
answer then, a 500 never, and no unit of work is left half stored.

`make test` runs 500 examples per route group on each database;
`make fuzz` sets HCSS_FUZZ_EXAMPLES for a long run (12,500: over 50,000
requests per database) and prints the tally by database, status and route.
"""

from __future__ import annotations

import os
from collections.abc import Iterator

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.support.fuzz import (
    EXAMPLES,
    FUZZ_SETTINGS,
    Target,
    console_requests,
    envelopes,
    live_requests,
    make_target,
    run_request,
    send,
    study_requests,
    write_tally,
)


@pytest.fixture
def target(database_url: str) -> Iterator[Target]:
    fuzzed = make_target(database_url)
    yield fuzzed
    write_tally(fuzzed)
    fuzzed.app.extensions["hcss_db"].engine.dispose()


@pytest.mark.slow
def test_fuzz_live_api(target: Target, caplog) -> None:
    @FUZZ_SETTINGS
    @given(data=st.data())
    def fuzz(data: st.DataObject) -> None:
        run_request(target, target.participant, data.draw(live_requests(target)), caplog)

    fuzz()


@pytest.mark.slow
def test_fuzz_study_pages(target: Target, caplog) -> None:
    @FUZZ_SETTINGS
    @given(data=st.data())
    def fuzz(data: st.DataObject) -> None:
        run_request(target, target.participant, data.draw(study_requests(target)), caplog)

    fuzz()


@pytest.mark.slow
def test_fuzz_console(target: Target, caplog) -> None:
    @FUZZ_SETTINGS
    @given(data=st.data())
    def fuzz(data: st.DataObject) -> None:
        request = data.draw(console_requests(target))
        signed_in = data.draw(st.booleans()) and request[1] != "/console/logout"
        run_request(target, target.console if signed_in else target.participant, request, caplog)

    fuzz()


@pytest.mark.slow
def test_fuzz_hosts_and_multipart_names(target: Target, caplog) -> None:
    """Malformed Host headers and multipart names on every route group."""

    @FUZZ_SETTINGS
    @given(data=st.data())
    def fuzz(data: st.DataObject) -> None:
        group = data.draw(st.sampled_from([live_requests, study_requests, console_requests]))
        request = data.draw(envelopes(data.draw(group(target))))
        client = target.console if group is console_requests else target.participant
        run_request(target, client, request, caplog)

    fuzz()


@pytest.mark.slow
def test_every_console_page_answers_after_failed_sign_ins_from_many_clients(
    database_url: str, caplog
) -> None:
    """5 failed sign-ins (any username, several clients, the rate limit on), then every page."""
    fuzzed = make_target(database_url, LOGIN_RATE_LIMIT=True)
    try:
        for address, username in (("10.0.0.1", "x"), ("10.0.0.2", "x"), ("10.0.0.1", "alice")):
            guesser = fuzzed.app.test_client()
            guesser.environ_base["REMOTE_ADDR"] = address
            for _ in range(6):  # the sixth is refused: locked
                fields = {"username": username, "password": "y"}
                send(fuzzed, guesser, "POST", "/console/login", data=fields)
        for path in (
            "/console/",
            "/console/progress.json",
            "/console/progress.json?page=2&hide=bot",
            f"/console/participants/{fuzzed.code}",
            f"/console/links?codes={fuzzed.code}",
            f"/console/links.csv?codes={fuzzed.code}",
            f"/console/trials/{fuzzed.trial_id}/replay",
            "/console/export.zip",
            "/console/login",
        ):
            run_request(fuzzed, fuzzed.console, ("GET", path, {}), caplog)
        assert fuzzed.console.get("/console/").status_code == 200
    finally:
        fuzzed.app.extensions["hcss_db"].engine.dispose()


@pytest.mark.slow
def test_fuzz_during_a_database_outage(tmp_path, caplog) -> None:
    """A full disk under SQLite while a trial runs: every route answers, 503 with Retry-After
    at worst, never a 500; the runner ticks between requests as the server's thread does."""
    from tests.support.own_disk import own_disk

    with own_disk(tmp_path) as disk:
        fuzzed = make_target(f"sqlite:///{disk.path / 'hcss.sqlite3'}")
        runner, engine = (
            fuzzed.app.extensions["hcss_runner"],
            fuzzed.app.extensions["hcss_db"].engine,
        )
        with engine.connect() as connection:
            connection.exec_driver_sql("PRAGMA wal_checkpoint(TRUNCATE)")
        disk.fill()
        fuzzed.database_away = True
        try:

            @settings(FUZZ_SETTINGS, max_examples=max(50, EXAMPLES // 5))
            @given(data=st.data())
            def fuzz(data: st.DataObject) -> None:
                group = data.draw(
                    st.sampled_from([live_requests, study_requests, console_requests])
                )
                client = fuzzed.console if group is console_requests else fuzzed.participant
                runner.clock.now += 0.5
                caplog.clear()
                runner.tick()
                method, path, options = data.draw(group(fuzzed))
                send(fuzzed, client, method, path, **options)

            fuzz()
        finally:
            disk.free()
            write_tally(fuzzed)
            engine.dispose()


@pytest.mark.slow
def test_fuzz_during_a_postgresql_outage(caplog) -> None:
    """PostgreSQL comes and goes while a trial runs and every route is fuzzed.

    The database is reached through a proxy whose line the test cuts and
    restores in stretches (open connections drop mid-use, new ones fail);
    the shared server is never stopped. While it is cut every answer is a
    503 with Retry-After that says the database is away, never a 500; once
    it is back, no unit of work is found half stored.
    """
    from sqlalchemy import create_engine
    from sqlalchemy.engine import make_url

    from benchmarks.relay import CutProxy
    from hcss.platform.serving.localserver import postgres_schema
    from tests.support.databases import PG_ENV

    base = os.environ.get(PG_ENV)
    if not base:
        pytest.skip(f"PostgreSQL tests need {PG_ENV}")
    server = make_url(base)
    with (
        postgres_schema(base, "hcss_fuzz") as direct,
        CutProxy(server.host or "127.0.0.1", server.port or 5432) as proxy,
    ):
        proxied = make_url(direct).set(host="127.0.0.1", port=proxy.port)
        fuzzed = make_target(proxied.render_as_string(hide_password=False))
        runner = fuzzed.app.extensions["hcss_runner"]
        fuzzed.database_away = True
        cuts = [0]
        try:

            @settings(FUZZ_SETTINGS, max_examples=max(50, EXAMPLES // 5))
            @given(data=st.data())
            def fuzz(data: st.DataObject) -> None:
                if data.draw(st.integers(0, 19)) == 0:  # stretches of about 20 requests
                    if proxy.cut_now:
                        proxy.restore()
                    else:
                        proxy.cut()
                        cuts[0] += 1
                group = data.draw(
                    st.sampled_from([live_requests, study_requests, console_requests])
                )
                client = fuzzed.console if group is console_requests else fuzzed.participant
                runner.clock.now += 0.5
                runner.tick()
                method, path, options = data.draw(group(fuzzed))
                send(fuzzed, client, method, path, **options)

            fuzz()
        finally:
            proxy.restore()
            write_tally(fuzzed)
            fuzzed.app.extensions["hcss_db"].engine.dispose()
        assert cuts[0] > 0 and fuzzed.tally  # the line was cut while requests were sent
        assert any(status == "503" for status, _ in fuzzed.tally)
        engine = create_engine(direct)
        try:
            assert _half_stored(engine) == {}
        finally:
            engine.dispose()


def _half_stored(engine) -> dict[str, int]:
    """Rows whose unit of work is incomplete: a command without its outcome, a participant
    with no trace of how they were made, a trial without its status."""
    from sqlalchemy import text

    checks = {
        "command without outcome": "SELECT count(*) FROM command c WHERE NOT EXISTS "
        "(SELECT 1 FROM command_outcome o WHERE o.command_id = c.id)",
        "participant made by nothing": "SELECT count(*) FROM participant p WHERE NOT p.is_bot "
        "AND NOT EXISTS (SELECT 1 FROM recruitment r WHERE r.participant_id = p.id) "
        "AND NOT EXISTS (SELECT 1 FROM console_action a WHERE a.participant_id = p.id "
        "AND a.action = 'create')",
        "trial without status": "SELECT count(*) FROM trial t WHERE NOT EXISTS "
        "(SELECT 1 FROM trial_status_change s WHERE s.trial_id = t.id)",
    }
    with engine.connect() as connection:
        found = {
            name: int(connection.execute(text(sql)).scalar() or 0) for name, sql in checks.items()
        }
    return {name: count for name, count in found.items() if count}
