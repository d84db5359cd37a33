"""Run the platform as a real server process on a loopback port.

The restart test kills it with SIGKILL, the browser test drives it with
Chromium, and the benchmark loads it with many trials: all need a server in
its own process, started with its own database and clock settings.

Part of the public testing API (docs/architecture.md): `make bench` and the
tests use it, so keep its interface stable.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
from pathlib import Path


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
        self.process: subprocess.Popen[bytes] | None = None
        self.log_path = self.instance_path / f"server-{self.port}.log"

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def start(self, timeout_s: float = 30.0) -> LocalServer:
        env = {
            **os.environ,
            "DATABASE_URL": self.database_url,
            "HCSS_INSTANCE_PATH": str(self.instance_path),
            "HCSS_SECRET_KEY": "local-server-secret",
            "HCSS_SNAPSHOT_INTERVAL_S": str(self.snapshot_interval_s),
            # The tests and the benchmark drive hundreds of pages from this one address;
            # a test of the per-client cap sets it in extra_env.
            "HCSS_CONNECTIONS_PER_CLIENT": "0",
            **self.extra_env,
        }
        command = [
            self.python,
            "-m",
            "hcss.platform",
            "serve",
            "--port",
            str(self.port),
            "--threads",
            str(self.threads),
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
