"""The console's links page, links.csv and the export at 5,000 participants.

A lab that pre-creates links for an online study, or runs a long one, has
thousands of participants: most never open their link, some walk the study.
The database is built once (SQLite in a temporary folder): 4,700 links never
opened, 296 participants enrolled and at their first stages, and 4 who walked
the whole demo study with its trials (participant bots). Each figure is the
wall time of one request (or export) and the SQL statements it sent.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

UNUSED = 4_700
ENROLLED = 296
WALKED = 4


def build(url: str):  # type: ignore[no-untyped-def]
    """The populated app (the demo study) and an experimenter's signed-in test client."""
    from hcss.platform.bots.participant import ParticipantBot, bot_app
    from hcss.platform.cli import upgrade_database
    from hcss.platform.console.accounts import create_experimenter
    from hcss.platform.console.participants import create_participants
    from hcss.platform.study.studyfile import load_study

    upgrade_database(url)
    app = bot_app(url, "demo", SECRET_KEY="bench", WTF_CSRF_ENABLED=False, TESTING=True)
    database = app.extensions["hcss_db"]
    clock = app.extensions["hcss_runner"].clock
    with app.app_context(), database.session_scope() as session:
        create_experimenter(session, "bench", "bench-password-1")
    with app.test_request_context(), database.session_scope() as session:
        made = create_participants(
            session,
            count=UNUSED + ENROLLED + WALKED,
            pilot=False,
            cell=None,
            experimenter=None,
            now=clock(),
            study="demo",
        )
        tokens = [p.token for p in made[UNUSED:]]
    client = app.test_client()
    for token in tokens[:ENROLLED]:
        client.get(f"/p/{token}", follow_redirects=True)  # enrolled, at the consent page
    study = load_study("demo")
    for number, token in enumerate(tokens[ENROLLED:]):
        ParticipantBot(app, token, seed=number).run(study)
    client.post("/console/login", data={"username": "bench", "password": "bench-password-1"})
    return app, client


def run() -> None:
    from sqlalchemy import event

    from hcss.platform.export.writer import write_export

    with tempfile.TemporaryDirectory() as folder:
        url = os.environ.get("HCSS_BENCH_DATABASE_URL") or (
            f"sqlite:///{Path(folder) / 'links-bench.sqlite3'}"
        )
        app, client = build(url)
        database = app.extensions["hcss_db"]
        statements = [0]

        def count(*_args) -> None:  # type: ignore[no-untyped-def]
            statements[0] += 1

        event.listen(database.engine, "before_cursor_execute", count)

        def measure(label: str, action) -> None:  # type: ignore[no-untyped-def]
            statements[0] = 0
            started = time.perf_counter()
            action()
            print(f"{label}: {time.perf_counter() - started:.2f} s, {statements[0]} statements")

        def page(path: str):  # type: ignore[no-untyped-def]
            def get() -> None:
                answer = client.get(path)
                assert answer.status_code == 200, answer.status_code

            return get

        total = UNUSED + ENROLLED + WALKED
        measure(f"/console/links, {total} participants", page("/console/links"))
        measure(f"/console/links.csv, {total} participants", page("/console/links.csv"))

        def export() -> None:
            with app.app_context(), database.session_scope() as session:
                write_export(session, Path(folder) / "export")

        measure(f"export, {total} participants", export)
        database.engine.dispose()
