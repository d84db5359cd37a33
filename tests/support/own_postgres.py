"""A PostgreSQL server of the test's own, which the test may stop and start again.

`initdb` in a temporary directory, on a free loopback port, run as the
``postgres`` user when the tests run as root (initdb refuses root). Skipped
when no PostgreSQL binaries are installed.
"""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import socket
import subprocess
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import pytest


def _binaries() -> Path | None:
    found = sorted(glob.glob("/usr/lib/postgresql/*/bin/initdb"))
    if found:
        return Path(found[-1]).parent
    initdb = shutil.which("initdb")
    return Path(initdb).parent if initdb else None


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@dataclass
class OwnPostgres:
    bin_dir: Path
    data_dir: Path
    port: int
    as_user: list[str]

    @property
    def url(self) -> str:
        return f"postgresql+psycopg://postgres@127.0.0.1:{self.port}/postgres"

    def _run(self, *args: str) -> None:
        subprocess.run(
            [*self.as_user, str(self.bin_dir / args[0]), *args[1:]],
            check=True,
            capture_output=True,
            timeout=60,
        )

    def start(self) -> None:
        options = f"-p {self.port} -k {self.data_dir} -c listen_addresses=127.0.0.1 -c fsync=off"
        log = str(self.data_dir / "server.log")
        self._run("pg_ctl", "-D", str(self.data_dir), "-l", log, "-o", options, "-w", "start")

    def stop(self) -> None:
        """Stop at once: open connections are cut, as when the database host goes away."""
        self._run("pg_ctl", "-D", str(self.data_dir), "-m", "immediate", "-w", "stop")


@contextmanager
def own_postgres() -> Iterator[OwnPostgres]:
    bin_dir = _binaries()
    if bin_dir is None:
        pytest.skip("needs PostgreSQL's initdb and pg_ctl")
    # Not under pytest's tmp_path: its parents are private to root, and the
    # server runs as postgres.
    home = Path(tempfile.mkdtemp(prefix="hcss-own-pg-"))
    home.chmod(0o755)
    data_dir = home / "pgdata"
    data_dir.mkdir()
    as_user: list[str] = []
    if os.geteuid() == 0:
        as_user = ["runuser", "-u", "postgres", "--"]
        shutil.chown(data_dir, "postgres")
    server = OwnPostgres(bin_dir, data_dir, _free_port(), as_user)
    try:
        server._run("initdb", "-D", str(data_dir), "-U", "postgres", "--auth=trust", "-E", "UTF8")
        server.start()
        yield server
    finally:
        with contextlib.suppress(subprocess.CalledProcessError):  # stopped, or never started
            server.stop()
        shutil.rmtree(home, ignore_errors=True)
