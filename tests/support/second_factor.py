"""A console account's second factor, enrolled and used as the lab does: through
`hcss admin second-factor`, with codes made by pyotp from the printed secret."""

from __future__ import annotations

import re
import threading
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor

import httpx
import pyotp
from click.testing import CliRunner

from tests.support.console import USERNAME
from tests.support.trials import csrf_token_of


def enrol(app, monkeypatch) -> tuple[pyotp.TOTP, list[str]]:
    """Enrol the test account from the shell; its TOTP and its ten recovery codes."""
    from hcss.cli import main as cli

    monkeypatch.setenv("DATABASE_URL", app.config["DATABASE_URL"])
    result = CliRunner().invoke(cli, ["admin", "second-factor", USERNAME])
    assert result.exit_code == 0, result.output
    secret = re.search(r"authenticator app: ([A-Z2-7]+)", result.output)
    assert secret and "otpauth://totp/" in result.output
    codes = re.findall(r"^ +([0-9a-f]{5}-[0-9a-f]{5})$", result.output, re.MULTILINE)
    assert len(codes) == 10 and len(set(codes)) == 10
    return pyotp.TOTP(secret.group(1)), codes


def sign_in(app, password: str, code: str = "", address: str = "10.0.0.1"):
    """The sign-in form posted from `address` with the test account's name."""
    client = app.test_client()
    client.environ_base["REMOTE_ADDR"] = address
    form = client.get("/console/login").get_data(as_text=True)
    fields = {"csrf_token": csrf_token_of(form), "username": USERNAME, "password": password}
    return client.post("/console/login", data={**fields, "code": code})


def next_step_code(totp: pyotp.TOTP) -> str:
    """A code of a later step than any used (the app shows a new one every 30 s)."""
    return totp.at(time.time() + totp.interval)


def sign_ins_at_once(
    base_url: str,
    count: int,
    fields: Callable[[int], dict[str, str]],
    *,
    subnet: str = "127.0.5",
    timeout: float = 60.0,
) -> list[int]:
    """`count` sign-ins from `count` loopback addresses (`subnet`.10 on), held at a barrier
    and sent together, as a crowd of browsers would; their statuses."""
    browsers = [
        httpx.Client(
            base_url=base_url,
            transport=httpx.HTTPTransport(local_address=f"{subnet}.{10 + number}"),
            timeout=timeout,
        )
        for number in range(count)
    ]
    tokens = [csrf_token_of(b.get("/console/login").text) for b in browsers]
    start = threading.Barrier(count)

    def sign_in(number: int) -> int:
        form = {"csrf_token": tokens[number], "username": USERNAME, **fields(number)}
        start.wait()
        return browsers[number].post("/console/login", data=form).status_code

    try:
        with ThreadPoolExecutor(count) as pool:
            return list(pool.map(sign_in, range(count)))
    finally:
        for browser in browsers:
            browser.close()
