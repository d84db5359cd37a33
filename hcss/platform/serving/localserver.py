"""Run the platform as a real server process on a loopback port.

The restart test kills it with SIGKILL, the browser test drives it with
Chromium, and the benchmark loads it with many trials: all need a server in
its own process, started with its own database and clock settings.

Part of the public testing API (docs/architecture.md): `make bench` and the
tests use it, so keep its interface stable.
"""

from __future__ import annotations

import os
import secrets
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def postgres_schema(base_url: str, prefix: str, *, options: str = "") -> Iterator[str]:
    """A fresh schema on the PostgreSQL server of `base_url`, dropped afterwards; its URL.

    Tests and benchmarks each get their own, so parallel runs and other
    people's databases never collide. `options`: more `-c` settings.
    """
    from sqlalchemy import create_engine, text
    from sqlalchemy.engine import make_url

    schema = f"{prefix}_{secrets.token_hex(6)}"
    admin = create_engine(base_url, isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(text(f'CREATE SCHEMA "{schema}"'))
    settings = f"-csearch_path={schema} {options}".strip()
    url = make_url(base_url).update_query_dict({"options": settings})
    try:
        yield url.render_as_string(hide_password=False)
    finally:
        with admin.connect() as connection:
            connection.execute(text(f'DROP SCHEMA "{schema}" CASCADE'))
        admin.dispose()


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


class LocalServer:
    """`python -m hcss.platform serve` in a subprocess; a context manager."""

    def __init__(
        self,
        database_url: str,
        instance_path: Path,
        *,
        port: int | None = None,
        threads: int = 32,
        snapshot_interval_s: float = 1.0,
        extra_env: dict[str, str] | None = None,
        python: str = sys.executable,
        serve_args: Sequence[str] = (),
        host: str = "127.0.0.1",
        lift_client_limits: bool = True,
    ) -> None:
        self.database_url = database_url
        self.instance_path = Path(instance_path)
        self.port = port or free_port()
        self.threads = threads
        self.snapshot_interval_s = snapshot_interval_s
        self.extra_env = extra_env or {}
        #: The interpreter that runs the server: another environment's, to serve what is
        #: installed there (the installed-wheel test).
        self.python = python
        #: More `serve` options (`--cluster` for a process of a group).
        self.serve_args = list(serve_args)
        self.host = host
        #: The per-address caps off, for tests and benchmarks that drive many
        #: participants from this one address; False keeps the server's defaults.
        self.lift_client_limits = lift_client_limits
        self.process: subprocess.Popen[bytes] | None = None
        self.log_path = self.instance_path / f"server-{self.port}.log"

    @property
    def url(self) -> str:
        return f"http://{self.host}:{self.port}"

    def start(self, timeout_s: float = 120.0) -> LocalServer:
        """Start and wait until it answers; `hcss serve` compiles the simulation first
        (up to about 25 s on an empty kernel cache), hence the long default wait."""
        # The tests and the benchmark drive hundreds of pages and streams from this
        # one address; a test of a per-client cap sets it in extra_env.
        lifted = {"HCSS_CONNECTIONS_PER_CLIENT": "0", "HCSS_STREAMS_PER_CLIENT": "1000000"}
        env = {
            **os.environ,
            "DATABASE_URL": self.database_url,
            "HCSS_INSTANCE_PATH": str(self.instance_path),
            "HCSS_SECRET_KEY": "local-server-secret",
            "HCSS_SNAPSHOT_INTERVAL_S": str(self.snapshot_interval_s),
            **(lifted if self.lift_client_limits else {}),
            **self.extra_env,
        }
        command = [
            self.python,
            "-m",
            "hcss.platform",
            "serve",
            "--host",
            self.host,
            "--port",
            str(self.port),
            "--threads",
            str(self.threads),
            *self.serve_args,
        ]
        self.instance_path.mkdir(parents=True, exist_ok=True)
        log = self.log_path.open("ab")
        # Started in the instance folder, so `-m` imports the installed hcss, never a
        # checkout that happens to be the caller's working directory.
        self.process = subprocess.Popen(
            command, env=env, cwd=self.instance_path, stdout=log, stderr=subprocess.STDOUT
        )
        log.close()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"server exited early:\n{self.log_path.read_text()}")
            try:
                with urllib.request.urlopen(self.url + "/", timeout=1):
                    return self
            except (urllib.error.URLError, ConnectionError, TimeoutError):
                time.sleep(0.1)
        self.stop()
        raise RuntimeError(f"server did not answer within {timeout_s} s")

    def kill(self) -> None:
        """SIGKILL: no shutdown code runs, as in a crash or a power cut."""
        if self.process is not None and self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
            self.process.wait(timeout=10)
        self.process = None

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait(timeout=10)
        self.process = None

    def __enter__(self) -> LocalServer:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()


def as_group(servers: Sequence[LocalServer]) -> list[LocalServer]:
    """Tell each server the group it is a member of (HCSS_GROUP), in the order `LocalNginx`
    is given their addresses, so trials are placed where nginx sends their participants."""
    group = ",".join(f"{server.host}:{server.port}" for server in servers)
    for server in servers:
        server.extra_env.setdefault("HCSS_GROUP", group)
    return list(servers)


class LocalNginx:
    """nginx in the foreground, configured by `hcss deploy nginx --standalone`, on a loopback port.

    Routes to the given `LocalServer`s (host:port each) as a deployment does;
    a context manager. `available()` says whether the binary is there.
    """

    BINARY = "/usr/sbin/nginx"

    def __init__(
        self,
        servers: Sequence[str],
        prefix: Path,
        *,
        port: int | None = None,
        tls: tuple[Path, Path] | None = None,
        access_log: bool = False,
    ) -> None:
        self.servers = list(servers)
        self.prefix = Path(prefix)
        self.port = port or free_port()
        #: (certificate, key): nginx speaks HTTPS and tells the servers so (X-Forwarded-Proto).
        self.tls = tls
        #: Log each request with the process(es) it was passed to and their answers
        #: (`access_log_path`): a detour through a process that answered 503 shows there.
        self.access_log = access_log
        self.process: subprocess.Popen[bytes] | None = None

    @classmethod
    def available(cls) -> bool:
        return os.access(cls.BINARY, os.X_OK)

    @property
    def url(self) -> str:
        return f"{'https' if self.tls else 'http'}://127.0.0.1:{self.port}"

    @property
    def access_log_path(self) -> Path:
        """Lines of `$request_uri $status $upstream_addr $upstream_status` (with `access_log`)."""
        return self.prefix / "access.log"

    def start(self, timeout_s: float = 10.0) -> LocalNginx:
        from hcss.platform.serving.nginx import standalone_config

        for folder in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
            (self.prefix / "temp" / folder).mkdir(parents=True, exist_ok=True)
        config = self.prefix / "nginx.conf"
        listen = f"127.0.0.1:{self.port}"
        text = standalone_config(self.servers, listen=listen, prefix=self.prefix)
        if os.geteuid() == 0:
            # Started by root, nginx's workers run as nobody, who cannot enter a test's
            # private folder: a body over the memory buffer (16 kB) then found its temp
            # file unwritable and nginx answered 500 itself (the fuzz through nginx).
            text = "user root;\n" + text
        if self.access_log:
            text = text.replace(
                "access_log off;",
                'log_format hcss_upstreams \'$msec $request_uri $status "$upstream_addr" '
                f'"$upstream_status"\';\n    access_log {self.access_log_path} hcss_upstreams;',
            )
        if self.tls is not None:
            certificate, key = self.tls
            text = text.replace(
                f"listen {listen};",
                f"listen {listen} ssl;\n        ssl_certificate {certificate};"
                f"\n        ssl_certificate_key {key};",
            )
        config.write_text(text)
        log = (self.prefix / "nginx.out").open("ab")
        self.process = subprocess.Popen(
            [self.BINARY, "-p", str(self.prefix), "-c", str(config)],
            stdout=log,
            stderr=subprocess.STDOUT,
        )
        log.close()
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            if self.process.poll() is not None:
                raise RuntimeError(f"nginx exited: {(self.prefix / 'error.log').read_text()}")
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=1):
                    return self
            except OSError:
                time.sleep(0.05)
        self.stop()
        raise RuntimeError(f"nginx did not listen within {timeout_s} s")

    def stop(self) -> None:
        if self.process is not None and self.process.poll() is None:
            self.process.terminate()
            self.process.wait(timeout=10)
        self.process = None

    def __enter__(self) -> LocalNginx:
        return self.start()

    def __exit__(self, *_exc: object) -> None:
        self.stop()
