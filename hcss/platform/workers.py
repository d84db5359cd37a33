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
    """Start the workers, wait until they stop; SIGTERM or Ctrl-C stops them all."""
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
            ]
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
