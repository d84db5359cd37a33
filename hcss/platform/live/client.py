"""A participant's browser, minus the browser: the trial page's HTTP calls.

Used by the restart test and the benchmark (and usable by participant bots):
it keeps the session cookie, reads the CSRF token from the page like the
page's script does, posts JSON commands and reads the SSE stream.

Part of the public testing API (docs/architecture.md): `make bench` and the
tests use it, so keep its interface stable.
"""

from __future__ import annotations

import http.cookiejar
import json
import re
import urllib.error
import urllib.request
from collections.abc import Iterator
from typing import Any


class TrialClient:
    def __init__(self, base_url: str, token: str) -> None:
        self.base_url = base_url.rstrip("/")
        self.token = token
        self.opener = urllib.request.build_opener(
            urllib.request.HTTPCookieProcessor(http.cookiejar.CookieJar())
        )
        self.csrf = ""
        self.trial_id: int | None = None

    def open_page(self) -> None:
        with self.opener.open(f"{self.base_url}/live/{self.token}", timeout=10) as response:
            html = response.read().decode()
        self.csrf = re.search(r'name="csrf-token" content="([^"]+)"', html).group(1)  # type: ignore[union-attr]
        self.trial_id = int(re.search(r"/trials/(\d+)/stream", html).group(1))  # type: ignore[union-attr]

    @property
    def api(self) -> str:
        return f"{self.base_url}/api/live/{self.token}/trials/{self.trial_id}"

    def state(self) -> dict[str, Any]:
        with self.opener.open(self.api + "/state", timeout=10) as response:
            return json.loads(response.read())

    def post(
        self, path: str, body: dict[str, Any], *, key: str | None = None
    ) -> tuple[int, dict[str, Any]]:
        """POST a command; with `key` as its Idempotency-Key (a repeat gets the first answer)."""
        headers = {"Content-Type": "application/json", "X-CSRFToken": self.csrf}
        if key is not None:
            headers["Idempotency-Key"] = key
        request = urllib.request.Request(
            self.api + path, data=json.dumps(body).encode(), headers=headers, method="POST"
        )
        try:
            with self.opener.open(request, timeout=10) as response:
                return response.status, json.loads(response.read())
        except urllib.error.HTTPError as error:
            return error.code, json.loads(error.read() or b"{}")

    def frames(self, timeout_s: float = 10.0) -> Iterator[dict[str, Any]]:
        """Stream frames as they arrive (close the generator to hang up)."""
        with self.opener.open(self.api + "/stream", timeout=timeout_s) as response:
            data: list[str] = []
            for raw in response:
                line = raw.decode().rstrip("\n")
                if line.startswith("data: "):
                    data.append(line[6:])
                elif line == "" and data:
                    yield json.loads("\n".join(data))
                    data = []
