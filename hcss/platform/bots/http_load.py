"""Participant bots against a real server over HTTP, many at once: the study's load tool.

`hcss bots --base-url URL --concurrency K` walks N bots through the whole
study on a running server (``hcss serve``), K at a time, each with its own
cookies, exactly the requests a browser sends (pages, forms, the live JSON
API), and reports errors and page latencies. The server runs the trials on
its own clock, so start it with the same study and a time acceleration,
e.g. ``HCSS_STUDY=demo hcss serve --time-acceleration 20``; bot participants
run at that acceleration (capped by the study file), real ones never do.

Bot participants are created in the server's database (``--database-url``,
default ``DATABASE_URL``), flagged ``is_bot``; the server enrols each on its
first visit, as it does a real participant. Target 127.0.0.1 only.
"""

from __future__ import annotations

import json
import re
import threading
import time
import urllib.parse
import uuid
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from types import SimpleNamespace
from typing import Any

import httpx

from hcss.platform.bots.participant import BotReport, ParticipantBot
from hcss.platform.db import Database
from hcss.platform.live.idempotency import KEY_HEADER
from hcss.platform.models import Participant
from hcss.platform.study.studyfile import load_study


@dataclass
class LoadFigures:
    """What a load run measured, across all bots."""

    bots: int
    concurrency: int
    wall_s: float = 0.0
    reports: list[BotReport] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    page_ms: list[float] = field(default_factory=list)
    api_ms: list[float] = field(default_factory=list)
    statuses: dict[int, int] = field(default_factory=dict)
    #: Latencies by route ("POST /p/<token>/stage/<n>/part_<n>"), to find the slow tail.
    route_ms: dict[str, list[float]] = field(default_factory=dict)
    lock: threading.Lock = field(default_factory=threading.Lock)

    def record(self, url: str, status: int, elapsed_s: float, method: str = "GET") -> None:
        milliseconds = elapsed_s * 1000.0
        with self.lock:
            (self.api_ms if "/api/" in url else self.page_ms).append(milliseconds)
            self.statuses[status] = self.statuses.get(status, 0) + 1
            self.route_ms.setdefault(route_of(method, url), []).append(milliseconds)

    def slowest_routes(self, count: int = 6) -> list[str]:
        """The routes with the most time in answers over 500 ms, the tail's makers, one line each.

        A page's time includes the redirect it leads to (a form's POST, then
        the GET of the next stage), as a participant waits for both.
        """
        slow = {
            route: sum(ms for ms in times if ms > SLOW_MS) for route, times in self.route_ms.items()
        }
        ranked = sorted(self.route_ms, key=lambda route: slow[route], reverse=True)[:count]
        return [
            f"{route}: {len(self.route_ms[route])} answers, "
            f"p50 {percentile(self.route_ms[route], 50):.0f} ms, "
            f"p95 {percentile(self.route_ms[route], 95):.0f} ms, "
            f"max {max(self.route_ms[route]):.0f} ms, "
            f"{sum(ms > SLOW_MS for ms in self.route_ms[route])} over {SLOW_MS:.0f} ms"
            for route in ranked
            if slow[route] > 0
        ]

    def summary(self) -> str:
        server_errors = sum(n for status, n in self.statuses.items() if status >= 500)
        return (
            f"{self.bots} bots ({self.concurrency} at a time) in {self.wall_s:.1f} s: "
            f"{len(self.reports)} completed, {len(self.errors)} failed, "
            f"{server_errors} answers >= 500 of {sum(self.statuses.values())}; "
            f"page p50 {percentile(self.page_ms, 50):.0f} ms, "
            f"p95 {percentile(self.page_ms, 95):.0f} ms; "
            f"live API p95 {percentile(self.api_ms, 95):.0f} ms"
        )


#: An answer slower than this counts towards the slow tail in `LoadFigures.slowest_routes`.
SLOW_MS = 500.0


def route_of(method: str, url: str) -> str:
    """`url` as its route: the participant token and the numbers replaced by placeholders."""
    path = urllib.parse.urlsplit(url).path
    path = re.sub(r"^/(p|live|api/live)/[^/]+", r"/\1/<token>", path)
    return f"{method} {re.sub(r'[0-9]+', '<n>', path)}"


def percentile(values: list[float], q: float) -> float:
    if not values:
        return float("nan")
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, max(0, round(q / 100 * (len(ordered) - 1))))]


#: While a server restarts: retries 0.25 s apart, for up to 60 s from the first try.
RECONNECT_FOR_S = 60.0
RECONNECT_WAIT_S = 0.25
#: A reverse proxy's answers when the process behind it dropped the request (killed
#: mid-answer) or could not be reached: for the bot, the same as a dropped connection.
GATEWAY_LOST = (502, 504)


class _Response(SimpleNamespace):
    """The part of Flask's test response the bot reads."""

    def get_data(self, as_text: bool = False) -> Any:
        return self.body.decode("utf-8", "replace") if as_text else self.body

    def get_json(self, silent: bool = False) -> Any:
        try:
            return json.loads(self.body)
        except ValueError:
            if silent:
                return None
            raise


class HttpClient:
    """A browser's cookies and requests over HTTP (httpx), with the test client's interface."""

    def __init__(self, base_url: str, figures: LoadFigures) -> None:
        self.base_url = base_url.rstrip("/")
        self.figures = figures
        self.http = httpx.Client(follow_redirects=True, timeout=60.0)

    def close(self) -> None:
        self.http.close()

    def get(self, url: str, follow_redirects: bool = True, **_: Any) -> _Response:
        return self._send("GET", url)[0]

    def post(
        self,
        url: str,
        data: dict[str, Any] | None = None,
        json: Any = None,  # the test client's name
        headers: dict[str, str] | None = None,
        follow_redirects: bool = True,
    ) -> _Response:
        headers = dict(headers or {})
        if json is not None:
            body = _json_bytes(json)
            headers["Content-Type"] = "application/json"
            # As the Collective Interface does: the server carries a key out once,
            # so this command can be sent again when its answer is lost.
            headers.setdefault(KEY_HEADER, uuid.uuid4().hex)
        else:
            body = urllib.parse.urlencode(data or {}, doseq=True).encode()
            headers["Content-Type"] = "application/x-www-form-urlencoded"
        response, repeated = self._send("POST", url, body, headers)
        if repeated and response.status_code == 409 and KEY_HEADER not in headers:
            # The lost form had been taken ("already submitted"): its address leads on
            # to the current page, as a participant reloading it would find.
            return self.get(url)
        return response

    def _send(
        self,
        method: str,
        url: str,
        body: bytes | None = None,
        headers: dict[str, str] | None = None,
    ) -> tuple[_Response, bool]:
        """The answer, and whether the request had to be sent more than once.

        A browser retries while the server restarts, and so does this client;
        it also asks again after a 503's Retry-After (the database is away, or
        the trial's process died and its lease has not yet run out), and after
        a proxy's 502 or 504 (nginx in front of a process killed mid-answer).
        A GET is safe to repeat. So is a POST: a command carries its
        Idempotency-Key (the server answers a repeat with the first outcome),
        and a stage form is taken once (a repeat is refused with 409).
        """
        started = time.perf_counter()
        tries = 0
        while True:
            tries += 1
            try:
                answer = self.http.request(
                    method, self.base_url + url, content=body, headers=headers
                )
            except httpx.TransportError:
                if time.perf_counter() - started >= RECONNECT_FOR_S:
                    raise
                time.sleep(RECONNECT_WAIT_S)
                continue
            if (
                answer.status_code in GATEWAY_LOST
                and time.perf_counter() - started < RECONNECT_FOR_S
            ):
                time.sleep(RECONNECT_WAIT_S)  # the proxy lost the process: as a dropped connection
                continue
            wait_s = _retry_after_s(answer)
            if wait_s is not None and time.perf_counter() - started + wait_s < RECONNECT_FOR_S:
                time.sleep(wait_s)  # the database is away: as the page does, ask again
                continue
            break
        self.figures.record(
            self.base_url + url, answer.status_code, time.perf_counter() - started, method
        )
        response = _Response(
            status_code=answer.status_code,
            body=answer.content,
            request=SimpleNamespace(path=answer.url.path),
        )
        return response, tries > 1


def _retry_after_s(answer: httpx.Response) -> float | None:
    """Seconds to wait before the same request again: a 503 that says Retry-After."""
    if answer.status_code != 503:
        return None
    try:
        return min(10.0, max(0.1, float(answer.headers.get("Retry-After", ""))))
    except ValueError:
        return None


def _json_bytes(value: Any) -> bytes:
    return json.dumps(value).encode()


def make_bot_participants(database_url: str, count: int) -> list[tuple[str, str]]:
    """(token, code) of `count` new bot participants, not yet enrolled."""
    database = Database(database_url)
    try:
        with database.session_scope() as session:
            made = [Participant(is_bot=True) for _ in range(count)]
            session.add_all(made)
            session.flush()
            return [(p.token, p.code) for p in made]
    finally:
        database.engine.dispose()


def run_http_bots(
    base_url: str,
    database_url: str,
    study_name: str,
    count: int,
    *,
    concurrency: int,
    seed: int = 0,
    progress: Callable[[], None] | None = None,
) -> LoadFigures:
    """Walk `count` bots through the study on the server at `base_url`, `concurrency` at once."""
    study = load_study(study_name)
    participants = make_bot_participants(database_url, count)
    figures = LoadFigures(bots=count, concurrency=concurrency)

    def walk(number: int) -> None:
        token, code = participants[number]
        client = HttpClient(base_url, figures)
        try:
            bot = ParticipantBot(None, token, seed=seed + number, client=client, code=code)
            report = bot.run(study)
            with figures.lock:
                figures.reports.append(report)
        except Exception as error:  # noqa: BLE001 - a failed bot is a figure, not a crash
            with figures.lock:
                figures.errors.append(f"{code}: {type(error).__name__}: {error}")
        finally:
            client.close()
        if progress is not None:
            progress()

    started = time.perf_counter()
    with ThreadPoolExecutor(max_workers=concurrency) as pool:
        list(pool.map(walk, range(count)))
    figures.wall_s = time.perf_counter() - started
    return figures
