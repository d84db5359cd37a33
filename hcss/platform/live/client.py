"""A participant's browser, minus the browser: the trial page's HTTP calls.

Used by the restart test and the benchmark (and usable by participant bots):
it keeps the session cookie, reads the CSRF token from the page like the
page's script does, posts JSON commands and reads the SSE stream.

Part of the public testing API (docs/architecture.md): `make bench` and the
tests use it, so keep its interface stable.
"""

from __future__ import annotations

import json
import re
import uuid
from collections.abc import Iterator
from typing import Any

import httpx
from httpx_sse import connect_sse


class TrialClient:
    def __init__(self, base_url: str, token: str, *, local_address: str | None = None) -> None:
        """`local_address`: the loopback address this participant connects from (127.x.y.z),
        so a benchmark's participants are as many clients as a study's, not one."""
        self.base_url = base_url.rstrip("/")
        self.token = token
        # httpx keeps the session cookie, as the browser does.
        transport = (
            None if local_address is None else httpx.HTTPTransport(local_address=local_address)
        )
        self.http = httpx.Client(timeout=10.0, transport=transport)
        self.csrf = ""
        self.trial_id: int | None = None

    def open_page(self) -> None:
        html = self.http.get(f"{self.base_url}/live/{self.token}").raise_for_status().text
        csrf = re.search(r'name="csrf-token" content="([^"]+)"', html)
        stream = re.search(r"/trials/(\d+)/stream", html)
        if csrf is None or stream is None:
            raise ValueError(f"/live/{self.token} is not a trial page")
        self.csrf, self.trial_id = csrf.group(1), int(stream.group(1))

    @property
    def api(self) -> str:
        return f"{self.base_url}/api/live/{self.token}/trials/{self.trial_id}"

    def state(self) -> dict[str, Any]:
        answer: dict[str, Any] = self.http.get(self.api + "/state").raise_for_status().json()
        return answer

    def post(
        self, path: str, body: dict[str, Any], *, key: str | None = None
    ) -> tuple[int, dict[str, Any]]:
        """POST a command with `key` as its Idempotency-Key (a repeat gets the first answer);
        a fresh one when none is given, as the page sends with every command."""
        headers = {"X-CSRFToken": self.csrf, "Idempotency-Key": key or uuid.uuid4().hex}
        response = self.http.post(self.api + path, json=body, headers=headers)
        return response.status_code, response.json() if response.content else {}

    def frames(self, timeout_s: float = 10.0) -> Iterator[dict[str, Any]]:
        """Stream frames as they arrive (close the generator to hang up)."""
        with connect_sse(self.http, "GET", self.api + "/stream", timeout=timeout_s) as source:
            for event in source.iter_sse():
                if event.data:
                    yield json.loads(event.data)

    def close(self) -> None:
        self.http.close()
