"""The fuzzer's route groups and request strategies, shared by tests/platform/test_fuzz.py
and test_fuzz_nginx.py: what a hostile or clumsy client sends to each route."""

from __future__ import annotations

import io
import logging
import os
from collections import Counter
from dataclasses import dataclass, field
from functools import cache
from typing import Any
from urllib.parse import quote, urlsplit

import numpy as np
from flask import Flask
from flask.testing import FlaskClient
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from werkzeug.exceptions import HTTPException

from hcss.platform.app import create_app
from hcss.platform.bots.participant import ManualClock
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.live.trials import start_bot_trial
from hcss.platform.study.stage_protocol import Shown
from hcss.platform.study.stages import STAGES
from tests.support.console import sign_in
from tests.support.trials import STUDY_TRIAL_S

EXAMPLES = int(os.environ.get("HCSS_FUZZ_EXAMPLES", "500"))
TALLY_FILE = os.environ.get("HCSS_FUZZ_TALLY")  # `make fuzz` collects the counts here

HUGE = [2**31 - 1, 2**31, 2**32, 2**53 + 1, 2**63 - 1, 2**63, 2**64, -(2**63) - 1, 10**40]
NASTY_TEXT = [
    "a\x00b",
    "\x00",
    "²",
    "\u00b2\u00b3",
    "9" * 5000,
    "-1",
    "1e9",
    "%00",
    "../",
    "' OR 1=1 --",
    "<script>",
    "🐝",
    "",
]

#: Values shaped like a header or a line of one: a client hoping a field reaches a header
#: (a redirect's Location, a CSV cell, a log line) unescaped.
HEADER_SHAPED = [
    "\r\nSet-Cookie: planted=1",
    "/console/\r\nLocation: https://evil.example/",
    "x\nX-Forwarded-Host: evil.example",
    "evil.example:444",
    "Host: evil.example",
    '=HYPERLINK("https://evil.example")',
]
#: Control characters (C0, DEL, C1) and the Unicode line and paragraph separators.
CONTROLS = [chr(code) for code in (*range(1, 32), *range(127, 160))] + ["\u2028", "\u2029"]

ints = st.one_of(st.integers(-5, 40), st.sampled_from(HUGE), st.integers())
#: Text with a control character inside, so every string field meets one.
controlled = st.builds(
    lambda head, control, tail: head + control + tail,
    st.text(max_size=12),
    st.sampled_from(CONTROLS),
    st.text(max_size=12),
)
texts = st.one_of(
    st.sampled_from(NASTY_TEXT), st.text(max_size=40), controlled, st.sampled_from(HEADER_SHAPED)
)
scalars = st.one_of(st.none(), st.booleans(), ints, st.floats(), texts)
json_values = st.recursive(
    scalars, lambda inner: st.lists(inner, max_size=4) | st.dictionaries(texts, inner, max_size=4)
)
command_bodies = st.fixed_dictionaries(
    {},
    optional={
        "kind": st.one_of(
            st.sampled_from(["investigate", "abandon", "decide", "cancel", "collective", "target"]),
            json_values,
        ),
        "collective": st.one_of(ints, json_values),
        "target": st.one_of(ints, json_values),
        "request_id": st.one_of(ints, json_values),
        "selections": st.one_of(st.lists(ints, max_size=40), json_values),
        "button": st.one_of(st.sampled_from(["left", "right"]), json_values),
        "answer": st.one_of(texts, json_values),
    },
)


@st.composite
def deep_json(draw: st.DrawFn) -> str:
    depth = draw(st.sampled_from([50, 999, 1000, 1001, 5000, 50000]))
    opener, closer = draw(st.sampled_from([("[", "]"), ('{"a":', "}")]))
    return opener * depth + ("1" if opener == "[" else "1") + closer * depth


@dataclass
class Target:
    """The fuzzed app and the real names in it."""

    app: Flask
    participant: FlaskClient
    console: FlaskClient
    token: str
    code: str
    trial_id: int
    tally: Counter[tuple[str, str]] = field(default_factory=Counter)
    database_away: bool = False  # during an outage a 503 with Retry-After is the answer

    @property
    def database(self) -> str:
        """The database kind, for the tally by database."""
        url = str(self.app.config["DATABASE_URL"])
        return "postgresql" if url.startswith("postgresql") else "sqlite"


def _segment(draw: st.DrawFn, real: Any) -> str:
    value = real if draw(st.integers(0, 9)) < 7 else draw(st.one_of(ints, texts))
    return quote(str(value), safe="")


def write_tally(fuzzed: Target) -> None:
    if TALLY_FILE:
        with open(TALLY_FILE, "a", encoding="utf-8") as handle:
            for (status, route), count in sorted(fuzzed.tally.items()):
                handle.write(f"{status} {count} {route} {fuzzed.database}\n")


def make_target(database_url: str, **config: Any) -> Target:
    app = create_app(
        {
            "DATABASE_URL": database_url,
            "SECRET_KEY": "fuzz-secret",
            "LIVE_RUNNER": False,
            "WTF_CSRF_ENABLED": False,
            "STREAM_MAX_S": 0.0,  # one frame, then the stream closes
            "STREAM_INTERVAL_S": 0.0,
            "LOGIN_RATE_LIMIT": False,
            "JOIN_PER_CLIENT": None,
            **config,
        }
    )
    app.extensions["hcss_db"].create_all()
    app.extensions["hcss_runner"].clock = ManualClock(0.0)
    with app.extensions["hcss_db"].session_scope() as session:
        create_experimenter(session, "alice", "correct horse battery")
        participant, trial = start_bot_trial(
            session, seed=2, duration_s=STUDY_TRIAL_S, time_acceleration=10.0
        )
        token, code, trial_id = participant.token, participant.code, trial.id
        app.extensions["hcss_runner"].clock.now = trial.started_at.timestamp() + 5.0
    console = app.test_client()
    assert sign_in(console, "alice", "correct horse battery").status_code == 302
    return Target(app, app.test_client(), console, token, code, trial_id)


def send(target: Target, client: FlaskClient, method: str, path: str, **options: Any) -> None:
    """One request; it must not answer 5xx, and nothing may be logged as an error."""
    response = client.open(path, method=method, **options)
    body = response.get_data()  # runs a stream's generator too
    target.tally[(str(response.status_code), _route(target.app, method, path))] += 1
    if target.database_away and response.status_code == 503:
        assert response.headers.get("Retry-After"), (method, path[:200])  # please wait, by design
        assert b"Traceback" not in body
        assert b"database" in body.lower(), (method, path[:200], body[:300])  # says why
        return
    assert response.status_code < 500, (method, path[:200], repr(options)[:300], body[:300])


def _route(app: Flask, method: str, path: str) -> str:
    """The endpoint a request reached (for the tally by route), or why none did."""
    try:
        endpoint, _ = app.url_map.bind("localhost").match(urlsplit(path).path, method=method)
    except HTTPException as refusal:
        return f"({refusal.code or 'no'}-route)"
    except Exception:  # noqa: BLE001 - an unroutable path is a route of its own for the tally
        return "(unroutable)"
    return f"{method}:{endpoint}"


def _body_options(draw: st.DrawFn, *, form_fields: tuple[str, ...] = ()) -> dict[str, Any]:
    """JSON mostly for the API, form fields mostly for pages; each sometimes gets the other."""
    kinds = (
        ["form", "form", "form", "json", "deep", "raw"]
        if form_fields
        else ["json", "json", "deep", "raw", "form"]
    )
    kind = draw(st.sampled_from(kinds))
    if kind == "json":
        return {"json": draw(st.one_of(command_bodies, json_values))}
    if kind == "deep":
        return {"data": draw(deep_json()), "content_type": "application/json"}
    if kind == "raw":
        return {
            "data": draw(st.binary(max_size=200)),
            "content_type": draw(st.sampled_from(["application/json", "text/plain", ""])),
        }
    names = form_fields or ("x",)
    fields = draw(st.dictionaries(st.sampled_from(names) | texts, texts, max_size=4))
    if fields and draw(st.integers(0, 4)) == 0:
        # A field sent as a multipart file part (a file's name and bytes): no page takes one.
        name = draw(st.sampled_from(sorted(fields)))
        fields[name] = as_file_part(fields[name], draw(st.sampled_from(FILE_NAMES)))
    return {"data": fields}


#: The file names a file part carries (an empty one is still a file part to werkzeug).
FILE_NAMES = ["field.txt", "", "../../etc/passwd", "a\x00b", "x" * 300]


def as_file_part(value: Any, filename: str) -> tuple[io.BytesIO, str]:
    """A form value as werkzeug's test client (and tests/platform/test_fuzz_nginx) sends a
    file: its bytes and a file name."""
    return io.BytesIO(str(value).encode("utf-8", "surrogatepass")), filename


@st.composite
def live_requests(draw: st.DrawFn, target: Target) -> tuple[str, str, dict[str, Any]]:
    token = _segment(draw, target.token)
    trial = _segment(draw, target.trial_id)
    base = f"/api/live/{token}/trials/{trial}"
    route = draw(
        st.sampled_from(["stream", "state", "requests", "observations", "ready", "answer", "page"])
    )
    if route == "page":
        return "GET", f"/live/{token}", {}
    if route in ("stream", "state"):
        after = quote(str(draw(st.one_of(ints, texts))), safe="")
        headers = {}
        if draw(st.booleans()):
            header = draw(st.one_of(texts, st.just("\xb2"), st.just("9" * 5000)))
            # Any bytes but line breaks (which end a header): UTF-8 read back as Latin-1.
            header = header.encode("utf-8", "replace").decode("latin-1")
            headers["Last-Event-ID"] = header.replace("\r", "").replace("\n", "")
        return "GET", f"{base}/{route}?after={after}", {"headers": headers}
    if route in ("ready", "answer"):
        probe = _segment(draw, 1)
        return "POST", f"{base}/probes/{probe}/{route}", _body_options(draw)
    return "POST", f"{base}/{route}", _body_options(draw)


@st.composite
def study_requests(draw: st.DrawFn, target: Target) -> tuple[str, str, dict[str, Any]]:
    token = _segment(draw, target.token)
    route = draw(st.sampled_from(["enter", "stage", "submit", "home", "heartbeat", "join"]))
    if route == "home":
        return "GET", "/", {}
    if route == "enter":
        return "GET", f"/p/{token}", {}
    if route == "stage":
        return "GET", f"/p/{token}/stage", {}
    if route == "heartbeat":
        return "POST", f"/p/{token}/heartbeat", _body_options(draw)
    if route == "join":
        study = _segment(draw, draw(st.sampled_from(["demo", "original"])))
        query = quote(str(draw(texts)), safe="")
        if draw(st.booleans()):
            return "GET", f"/join/{study}?PROLIFIC_PID={query}", {}
        fields = ("PROLIFIC_PID", "STUDY_ID", "SESSION_ID", "id", "screen_width", "pointer")
        return "POST", f"/join/{study}", _body_options(draw, form_fields=fields)
    index = _segment(draw, 0)
    step = draw(st.sampled_from(["form", "ratings", "ready", "part_1", "page_1"]))
    fields = (*_stage_fields(step), "answer", "submit")
    return (
        "POST",
        f"/p/{token}/stage/{index}/{_segment(draw, step)}",
        _body_options(draw, form_fields=fields),
    )


@cache
def _stage_fields(step: str) -> tuple[str, ...]:
    """The fields the stages' own bot submissions post at a step (valid or refused)."""
    shown = Shown(step, np.random.default_rng(0))
    return tuple(
        sorted(
            {
                name
                for stage in STAGES.values()
                for submission in stage.bot_submissions(shown)
                for name in submission.fields
            }
        )
    )


LOGIN_FIELDS = ("username", "password", "code")


@st.composite
def console_requests(draw: st.DrawFn, target: Target) -> tuple[str, str, dict[str, Any]]:
    code = _segment(draw, target.code)
    route = draw(
        st.sampled_from(
            [
                "login_get",
                "login",
                "logout",
                "index",
                "progress",
                "create",
                "show",
                "act",
                "withdraw",
                "export",
                "links",
                "replay",
                "table",
            ]
        )
    )
    if route == "login_get":
        return "GET", f"/console/login?next={quote(draw(texts), safe='')}", {}
    if route == "login":
        if draw(st.booleans()):
            return "POST", "/console/login", _body_options(draw, form_fields=LOGIN_FIELDS)
        # The right password, so `next` (a console page, then anything) and the code reach
        # the redirect: a next with CR/LF there answered 500.
        fields = {"username": "alice", "password": "correct horse battery", "code": draw(texts)}
        page = draw(st.sampled_from(["/console/", "/console/links?codes=", ""])) + draw(texts)
        if draw(st.integers(0, 4)) == 0:
            name = draw(st.sampled_from(LOGIN_FIELDS))
            fields[name] = as_file_part(fields[name], draw(st.sampled_from(FILE_NAMES)))
        return "POST", f"/console/login?next={quote(page, safe='')}", {"data": fields}
    if route == "logout":
        return "POST", "/console/logout", {"headers": {"X-Logout": "anonymous"}}
    if route == "index":
        return "GET", "/console/", {}
    if route == "progress":
        return "GET", "/console/progress.json", {}
    if route == "export":
        return "GET", "/console/export.zip", {}
    if route == "create":
        return (
            "POST",
            "/console/participants",
            _body_options(draw, form_fields=("count", "pilot", "cell")),
        )
    if route == "show":
        return "GET", f"/console/participants/{code}", {}
    if route == "links":
        codes = ",".join([code, quote(str(draw(texts)), safe="")][: draw(st.integers(1, 2))])
        return "GET", f"/console/{draw(st.sampled_from(['links', 'links.csv']))}?codes={codes}", {}
    if route == "replay":
        trial = _segment(draw, target.trial_id)
        part = draw(st.sampled_from(["", "/frames", "/timeline"]))
        query = f"?from={quote(str(draw(st.one_of(ints, texts))), safe='')}"
        return "GET", f"/console/trials/{trial}/replay{part}{query}", {}
    if route == "table":
        page = quote(str(draw(st.one_of(ints, texts))), safe="")
        hide = quote(str(draw(st.one_of(st.sampled_from(["pilot,bot,demo", "bot"]), texts))))
        return "GET", f"/console/progress.json?page={page}&hide={hide}", {}
    if route == "withdraw":
        return (
            "POST",
            f"/console/participants/{code}/withdraw",
            _body_options(draw, form_fields=("confirm_code",)),
        )
    action = _segment(
        draw, draw(st.sampled_from(["pause", "resume", "abort", "mark_pilot", "unmark_pilot"]))
    )
    return "POST", f"/console/participants/{code}/{action}", {}


FUZZ_SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=None,
    derandomize=EXAMPLES <= 500,  # the suite's run is repeatable; `make fuzz` explores
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    database=None,
)


#: Host headers that are not hostnames: a label over 63 characters, an empty label, junk.
BAD_HOSTS = [
    "a" * 64 + ".example",
    "a..b",
    ".",
    "x" * 300,
    "[::1",
    "h\u00e9.example",
    "1.2.3.4:99999",
]
#: Headers a proxy sets, and headers the app reads from a client.
FORWARDED_HEADERS = [
    "X-Forwarded-Host",
    "X-Forwarded-Port",
    "X-Forwarded-For",
    "X-Forwarded-Proto",
    "X-Forwarded-Prefix",
    "Idempotency-Key",
    "Referer",
    "Origin",
]


def _header_value(value: str) -> str:
    """What a header can carry: any bytes but line breaks, UTF-8 read back as Latin-1."""
    value = value.encode("utf-8", "replace").decode("latin-1")
    return value.replace("\r", "").replace("\n", "")


#: Multipart field names werkzeug reads oddly (a lone backslash parses to no name).
BAD_FIELD_NAMES = ["\\", '\\"', "", "a\x00b", "\u00b2", "x" * 500]


@st.composite
def envelopes(
    draw: st.DrawFn, request: tuple[str, str, dict[str, Any]]
) -> tuple[str, str, dict[str, Any]]:
    """The request, sometimes with a Host that is no hostname or a hostile multipart body."""
    method, path, options = request
    options = dict(options)
    if draw(st.integers(0, 3)) == 0:
        options["headers"] = {
            **options.get("headers", {}),
            "Host": draw(st.sampled_from(BAD_HOSTS)),
        }
    if draw(st.integers(0, 3)) == 0:
        # A client's own forwarding headers (trusted only from the proxy) and header-shaped
        # values in the headers the app reads.
        name = draw(st.sampled_from(FORWARDED_HEADERS))
        value = draw(st.one_of(st.sampled_from(HEADER_SHAPED + BAD_HOSTS), texts))
        options["headers"] = {**options.get("headers", {}), name: _header_value(value)}
    if method == "POST" and draw(st.integers(0, 3)) == 0:
        name = draw(st.sampled_from(BAD_FIELD_NAMES))
        boundary = "fuzz-boundary"
        body = (
            f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"\r\n\r\n'
            f"{draw(texts)}\r\n--{boundary}--\r\n"
        ).encode("utf-8", "surrogatepass")
        options.pop("json", None)
        options["data"] = body
        options["content_type"] = f"multipart/form-data; boundary={boundary}"
    return method, path, options


def run_request(
    target: Target, client: FlaskClient, request: tuple[str, str, dict[str, Any]], caplog
) -> None:
    method, path, options = request
    caplog.clear()
    with caplog.at_level(logging.ERROR):
        send(target, client, method, path, **options)
    errors = [r for r in caplog.records if r.levelno >= logging.ERROR]
    assert not errors, [r.getMessage()[:300] for r in errors][:3]
