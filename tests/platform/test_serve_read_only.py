"""`hcss serve` on a database that takes no writes says so at start, loudly.

It starts all the same (the pool uses the database once it is writable, see
test_database_recovery.py), but an operator reading the terminal learns at
once why every participant would get a "please wait" page.
"""

from __future__ import annotations

import os
import selectors
import socket
import subprocess
import sys
import time
from pathlib import Path

from hcss.platform.app import create_app
from hcss.platform.db import Database
from tests.support.own_disk import own_disk
from tests.support.recruitment import join

HCSS = str(Path(sys.executable).with_name("hcss"))


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _stderr_until(process: subprocess.Popen, needle: str, limit_s: float) -> str:
    """What the process wrote on stderr until `needle` (or its exit, or the limit)."""
    assert process.stderr is not None
    os.set_blocking(process.stderr.fileno(), False)
    seen = b""
    with selectors.DefaultSelector() as selector:
        selector.register(process.stderr, selectors.EVENT_READ)
        deadline = time.monotonic() + limit_s
        while needle.encode() not in seen and time.monotonic() < deadline:
            if selector.select(timeout=0.5):
                chunk = process.stderr.read()
                if not chunk and process.poll() is not None:
                    break
                seen += chunk or b""
    return seen.decode(errors="replace")


def test_serve_warns_at_start_that_a_read_only_database_takes_no_writes(tmp_path) -> None:
    with own_disk(tmp_path) as disk:
        url = f"sqlite:///{disk.path / 'hcss.sqlite3'}"
        setup = Database(url)
        setup.create_all()
        setup.engine.dispose()
        disk.read_only()
        try:
            environment = {
                **os.environ,
                "DATABASE_URL": url,
                "HCSS_INSTANCE_PATH": str(tmp_path / "instance"),
                "HCSS_SECRET_KEY": "s",
            }
            process = subprocess.Popen(
                [HCSS, "serve", "--port", str(_free_port())],
                env=environment,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.PIPE,
            )
            try:
                said = _stderr_until(process, "no console login created", 60)
            finally:
                process.terminate()
                process.wait(timeout=10)
            assert "WARNING: the database takes no writes" in said, said
            assert "hcss.sqlite3" in said and "please wait" in said
            assert "Traceback" not in said
            # No first login can be made, and migrating is not what it takes.
            assert "hcss db upgrade" not in said, said
            assert "next start on a database that takes writes" in said, said
            assert Database(url).write_refusal()  # the driver's reason
        finally:
            disk.writable()
        assert Database(url).write_refusal() is None  # writable: nothing to say


def test_a_read_only_postgresql_is_said_at_start_and_answers_503() -> None:
    """As on a standby, or with default_transaction_read_only: `hcss serve`'s probe is
    refused, and a participant's Start answers 503 with Retry-After, not 500 (PostgreSQL
    raises no OperationalError for it, but ReadOnlySqlTransaction, SQLSTATE 25006)."""
    import pytest

    from hcss.platform.serving.localserver import postgres_schema
    from tests.support.databases import PG_ENV

    base = os.environ.get(PG_ENV)
    if not base:
        pytest.skip(f"PostgreSQL tests need {PG_ENV}")
    with postgres_schema(base, "hcss_test") as url:
        writable = Database(url)
        writable.create_all()
        assert writable.write_refusal() is None
        writable.engine.dispose()
        read_only = Database(
            url.replace("options=", "options=-cdefault_transaction_read_only%3Don+")
        )
        try:
            refusal = read_only.write_refusal()
            assert refusal is not None and "read-only transaction" in refusal
        finally:
            read_only.engine.dispose()
        app = create_app({"DATABASE_URL": read_only.url, "SECRET_KEY": "s"})
        try:
            refused = join(app.test_client())
            assert refused.status_code == 503 and int(refused.headers["Retry-After"]) > 0
            assert "please wait" in refused.get_data(as_text=True).lower()
        finally:
            app.extensions["hcss_db"].engine.dispose()
