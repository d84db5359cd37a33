"""`hcss serve --processes N`: N server processes on consecutive ports, one database.

Each worker is `hcss serve --cluster` on its own port, so it hosts live
trials by lease (hcss.platform.live.leases) and any of them can take over a
trial whose process died. The group only starts and stops them; nginx (see
`hcss deploy nginx`) spreads the participants over them. A worker that dies
is not restarted here: its trials move to the others within a lease, and a
service manager (systemd, one unit per port) is the tool for restarts.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from types import FrameType
from typing import Any

from sqlalchemy.engine import make_url


class GroupRefused(Exception):
    """The database cannot be shared by several processes."""


def require_shared_database(database_url: str) -> None:
    """Several processes need PostgreSQL: SQLite is the embedded, single-process database."""
    if make_url(database_url).get_backend_name() != "postgresql":
        raise GroupRefused(
            "several server processes need PostgreSQL (set DATABASE_URL to a "
            "postgresql+psycopg:// URL); SQLite serves one process only, so start "
            "`hcss serve` without --processes or --cluster"
        )


def process_name(host: str, port: int) -> str:
    """The name a worker leases trials under: its address and a token new at every start.

    The address says where it listens (the console shows it); the token makes
    the name unique per start, so two processes that share an address (cloned
    hosts, `--host 127.0.0.1` on two machines) or a process restarted on its
    old address never take each other for the holder of a lease. A restarted
    process waits for its predecessor's leases to run out like any other.
    """
    import os
    import secrets

    if host in ("0.0.0.0", "::", ""):
        import socket

        host = socket.gethostname()
    return f"{host}:{port}/{os.getpid()}-{secrets.token_hex(4)}"


def run_group(processes: int, host: str, port: int, worker_args: Sequence[str]) -> int:
    """Start the workers, wait until they stop; SIGTERM or Ctrl-C stops them all.

    Each worker is told the group (HCSS_GROUP: the members in the order `hcss deploy
    nginx` lists them for the same --host, --port and --processes), unless set already.
    """
    import os

    group = os.environ.get("HCSS_GROUP") or ",".join(
        f"{host}:{port + index}" for index in range(processes)
    )
    workers = [
        subprocess.Popen(
            [
                sys.executable,
                "-m",
                "hcss.platform",
                "serve",
                "--cluster",
                "--host",
                host,
                "--port",
                str(port + index),
                *worker_args,
            ],
            env={**os.environ, "HCSS_GROUP": group},
        )
        for index in range(processes)
    ]

    def stop(_signal: int, _frame: FrameType | None) -> None:
        for worker in workers:
            if worker.poll() is None:
                worker.terminate()

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    while any(worker.poll() is None for worker in workers):
        time.sleep(0.5)
    return max((worker.returncode or 0) for worker in workers)


#: A process of the group that has not said it is alive for this long is gone: its study
#: files no longer bind a process starting now (a heartbeat every `BEAT_S`).
MEMBER_GONE_S = 30.0
BEAT_S = 5.0


def served_studies() -> dict[str, str]:
    """The digest of every study file this process can load, by study name."""
    from hcss.platform.study.files import StudyFileError, study_names
    from hcss.platform.study.studyfile import load_study

    digests = {}
    for name in study_names():
        try:
            digests[name] = load_study(name).digest
        except StudyFileError:
            continue  # `hcss serve` lists it as a problem at start; nobody enrols in it
    return digests


def require_same_studies(database: Any, process: str, studies: dict[str, str]) -> None:
    """Record this process's study files for the group, or GroupRefused if a live member
    serves another file for one of them (the digests differ).

    Checked and recorded in one transaction with the rows locked, so of two
    processes starting at once with different files, the second refuses. Ages
    are read on PostgreSQL's clock, so the hosts' clocks never meet.
    """
    from sqlalchemy import select
    from sqlalchemy.dialects.postgresql import insert

    from hcss.platform.models import GroupStudy

    with database.session_scope() as session:
        now = _database_now(session)
        rows = session.scalars(
            select(GroupStudy).where(GroupStudy.study.in_(studies)).with_for_update()
        ).all()
        for row in rows:
            age_s = now - row.seen_epoch
            if row.digest != studies[row.study] and age_s < MEMBER_GONE_S:
                raise GroupRefused(
                    f"study {row.study}: this process's file (sha256 "
                    f"{studies[row.study][:12]}) is not the one the group serves (sha256 "
                    f"{row.digest[:12]}, process {row.process}, alive {age_s:.0f} s ago). "
                    "Every process of a group must serve the same study files: copy the "
                    "group's file here, or stop every process before changing a study "
                    "(docs/operations.md, Rolling upgrade)"
                )
        for study, digest in studies.items():
            values = {"study": study, "digest": digest, "process": process, "seen_epoch": now}
            session.execute(
                insert(GroupStudy)
                .values(**values)
                .on_conflict_do_update(index_elements=["study"], set_=values)
            )


def say_alive(database: Any, studies: dict[str, str]) -> None:
    """This process still serves these files: their rows' `seen_epoch` moves on."""
    from sqlalchemy import and_, or_, update

    from hcss.platform.models import GroupStudy

    if not studies:
        return
    with database.session_scope() as session:
        session.execute(
            update(GroupStudy)
            .where(
                or_(
                    *(
                        and_(GroupStudy.study == study, GroupStudy.digest == digest)
                        for study, digest in studies.items()
                    )
                )
            )
            .values(seen_epoch=_database_now(session))
        )


def _database_now(session: Any) -> float:
    from sqlalchemy import text

    return float(session.scalar(text("SELECT extract(epoch FROM clock_timestamp())")))


def hold_studies(database_url: str, process: str) -> None:
    """At a group process's start, before its app: refuse a study file the group serves
    otherwise (GroupRefused), else record ours and say every `BEAT_S` that we serve them."""
    import threading
    import time as wallclock

    from sqlalchemy.exc import DBAPIError

    from hcss.platform.db import Database

    database = Database(database_url)
    studies = served_studies()
    require_same_studies(database, process, studies)

    def beat() -> None:
        while True:
            wallclock.sleep(BEAT_S)
            try:
                say_alive(database, studies)
            except DBAPIError:  # the database is away: the next beat tries again
                continue

    threading.Thread(target=beat, name="hcss-group-studies", daemon=True).start()
