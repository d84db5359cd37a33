"""kill -9 the server repeatedly while bots walk the demo study over HTTP (issue 13 acceptance).

    .venv/bin/python scripts/kill9_under_load.py [--bots 8] [--rounds 4] [--every 6]

A waitress server (its own process, SQLite unless DATABASE_URL is given)
runs the demo study at time acceleration 20; `hcss.platform.bots.http_load` walks
the bots concurrently. Every EVERY seconds the script records the id of
every committed row, sends SIGKILL, waits a second, starts a new server on
the same database, and checks that every recorded row is still there. At the
end: rows lost (must be 0), interruptions recorded, trials ended on their
time limit, bots completed. Loopback only; bounded in rounds and time.
"""

from __future__ import annotations

import argparse
import os
import threading
import time
from pathlib import Path
from tempfile import TemporaryDirectory

from sqlalchemy import select

from hcss.platform.bots.http_load import run_http_bots
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import Base, Interruption, TrialStatusChange
from hcss.platform.serving.localserver import LocalServer


def committed_ids(database: Database) -> dict[str, set[int]]:
    with database.session_scope() as session:
        return {
            table.name: set(session.scalars(select(table.c.id)))
            for table in Base.metadata.sorted_tables
            if "id" in table.c and table.name not in ("deletion_permit", "login_failure")
        }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--bots", type=int, default=8)
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--every", type=float, default=6.0, help="seconds between kills")
    args = parser.parse_args()
    with TemporaryDirectory() as tmp:
        url = os.environ.get("DATABASE_URL") or f"sqlite:///{Path(tmp) / 'kill9.sqlite3'}"
        upgrade_database(url)
        database = Database(url)
        env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": "20"}
        server = LocalServer(url, Path(tmp) / "instance", threads=64, extra_env=env).start()
        result: dict[str, object] = {}
        walker = threading.Thread(
            target=lambda: result.update(
                figures=run_http_bots(server.url, url, "demo", args.bots, concurrency=args.bots)
            )
        )
        walker.start()
        lost = 0
        for round_number in range(1, args.rounds + 1):
            time.sleep(args.every)
            if not walker.is_alive():
                break
            before = committed_ids(database)
            server.kill()
            time.sleep(1.0)
            server.start()
            after = committed_ids(database)
            missing = sum(len(ids - after.get(name, set())) for name, ids in before.items())
            lost += missing
            print(
                f"round {round_number}: {sum(map(len, before.values()))} committed rows at the "
                f"kill, {missing} missing after the restart"
            )
        walker.join(timeout=600)
        server.stop()
        figures = result.get("figures")
        with database.session_scope() as session:
            interruptions = len(session.scalars(select(Interruption)).all())
            reasons = session.scalars(
                select(TrialStatusChange.reason).where(TrialStatusChange.status == "ended")
            ).all()
        database.engine.dispose()
    print(f"rows lost: {lost}; interruptions recorded: {interruptions}")
    print(f"trials ended: {len(reasons)} ({', '.join(sorted(set(reasons)))})")
    print(figures.summary() if figures is not None else "bots did not finish")  # type: ignore[attr-defined]
    for error in getattr(figures, "errors", [])[:10]:
        print(f"  failed: {error}")
    return 0 if lost == 0 and figures is not None and not figures.errors else 1  # type: ignore[attr-defined]


if __name__ == "__main__":
    raise SystemExit(main())
