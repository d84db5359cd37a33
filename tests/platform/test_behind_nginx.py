"""Issue 30 §1: behind the documented nginx, every visitor is still their own client.

A real `hcss serve` (SQLite, study demo, its own limits: nothing lifted for
one address) behind the nginx of `hcss deploy nginx`, speaking HTTPS, with
``HCSS_PROXY_HOPS=1``. Each visitor is a distinct loopback address
(127.0.0.x) talking to nginx, so the server sees them only through the
proxy's X-Forwarded-For. Waitress 3 removes X-Forwarded-* from any peer it was
not told to trust, and `hcss serve` told it of none: 40 Starts from 40
addresses got 10 x 429, 60 streams 4 x 503, and the lab was locked out by a
guesser elsewhere.
"""

from __future__ import annotations

import re
import signal
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
import pytest
from sqlalchemy import select

from hcss.platform.cli import DEFAULT_THREADS, upgrade_database
from hcss.platform.console.accounts import create_experimenter
from hcss.platform.db import Database
from hcss.platform.live.trials import start_trial
from hcss.platform.models import Participant
from hcss.platform.serving.localserver import LocalNginx, LocalServer
from tests.support.trials import csrf_token_of

pytestmark = pytest.mark.slow

USERNAME, PASSWORD = "lab", "a long enough password"
LAPTOP = {"width": "1366", "height": "768", "mobile": "0", "missing": ""}
HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')


@dataclass
class Proxied:
    server: LocalServer
    nginx: LocalNginx
    database: Database

    def visitor(self, address: str, *, direct: bool = False) -> httpx.Client:
        """A browser on loopback address `address`, to nginx (or straight to the server)."""
        transport = httpx.HTTPTransport(local_address=address, verify=False)
        base = self.server.url if direct else self.nginx.url
        # No Referer, as a browser sends none under the pages' Referrer-Policy: no-referrer.
        return httpx.Client(base_url=base, transport=transport, verify=False, timeout=30.0)


def _certificate(folder: Path) -> tuple[Path, Path]:
    certificate, key = folder / "cert.pem", folder / "key.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1"]
        + ["-subj", "/CN=127.0.0.1", "-keyout", str(key), "-out", str(certificate)],
        check=True,
        capture_output=True,
    )
    return certificate, key


@pytest.fixture(scope="module")
def proxied(tmp_path_factory) -> Iterator[Proxied]:
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY} (scripts/ensure-nginx installs it)")
    folder = tmp_path_factory.mktemp("behind-nginx")
    url = f"sqlite:///{folder / 'proxied.sqlite3'}"
    upgrade_database(url)
    database = Database(url)
    with database.session_scope() as session:
        create_experimenter(session, USERNAME, PASSWORD)
    server = LocalServer(
        url,
        folder / "instance",
        threads=DEFAULT_THREADS,  # as `hcss serve` runs: stream ceiling and shares its own
        lift_client_limits=False,
        serve_args=["--study", "demo"],
        extra_env={"HCSS_PROXY_HOPS": "1"},
    )
    with (
        server,
        LocalNginx(
            [f"127.0.0.1:{server.port}"], folder / "nginx", tls=_certificate(folder)
        ) as nginx,
    ):
        yield Proxied(server, nginx, database)
    database.engine.dispose()


def _start(client: httpx.Client) -> httpx.Response:
    """Open the study link and press Start, as a laptop's browser does."""
    first = client.get("/join/demo")
    if first.status_code != 200 or 'id="join-form"' not in first.text:
        return first
    return client.post("/join/demo", data=dict(HIDDEN.findall(first.text)) | LAPTOP)


def test_forty_visitors_from_forty_addresses_all_enrol(proxied) -> None:
    statuses = []
    for number in range(40):
        with proxied.visitor(f"127.0.0.{10 + number}") as visitor:
            statuses.append(_start(visitor).status_code)
    assert statuses == [302] * 40


def test_sixty_participants_from_sixty_addresses_all_get_their_stream(proxied) -> None:
    tokens = []
    with proxied.database.command_scope() as session:
        for _ in range(60):
            participant = Participant(is_demo=True, study="demo")
            session.add(participant)
            session.flush()
            start_trial(session, participant, kind="trial", duration_s=600.0)
            tokens.append(participant.token)
    visitors, streams, statuses = [], [], []
    try:
        for number, token in enumerate(tokens):
            visitor = proxied.visitor(f"127.0.1.{10 + number}")
            visitors.append(visitor)
            page = visitor.get(f"/live/{token}").raise_for_status().text
            stream_path = re.search(r"/api/live/[^\"']+/trials/\d+/stream", page)
            assert stream_path is not None
            stream = visitor.stream("GET", stream_path.group(0))
            response = stream.__enter__()
            streams.append(stream)
            statuses.append(response.status_code)
            if response.status_code == 200:  # a live trial's stream, not an ended trial's frame
                assert next(response.iter_bytes()).startswith(b"retry: 1000")
    finally:
        for stream in streams:
            stream.__exit__(None, None, None)
        for visitor in visitors:
            visitor.close()
    assert statuses == [200] * 60


def _sign_in(client: httpx.Client, password: str) -> httpx.Response:
    form = client.get("/console/login")
    fields = {"csrf_token": csrf_token_of(form.text), "username": USERNAME, "password": password}
    return client.post("/console/login", data={**fields, "code": ""})


def test_the_lab_signs_in_while_a_guesser_elsewhere_is_locked_out(proxied) -> None:
    with proxied.visitor("127.0.2.66") as guesser:
        guesses = [_sign_in(guesser, "wrong password").status_code for _ in range(6)]
    with proxied.visitor("127.0.2.77") as lab:
        signed_in = _sign_in(lab, PASSWORD)
    assert guesses == [401] * 5 + [429]
    assert signed_in.status_code == 302
    cookie = signed_in.headers["set-cookie"]
    assert "Secure" in cookie and "HttpOnly" in cookie  # nginx speaks HTTPS: X-Forwarded-Proto


def test_an_untrusted_peer_cannot_claim_an_address_and_is_logged_once(proxied) -> None:
    """Straight to the server from 127.0.3.x (not the proxy): its X-Forwarded-* are dropped."""
    forged = {"X-Forwarded-For": "198.51.100.1", "X-Forwarded-Proto": "https"}
    with proxied.visitor("127.0.3.1", direct=True) as visitor:
        guesses = [
            visitor.post("/console/login", headers=forged).status_code,  # no CSRF: 400
            _sign_in(visitor, "wrong").status_code,
        ]
        for _ in range(4):
            visitor.headers.update(forged)
            _sign_in(visitor, "wrong")
        refused = _sign_in(visitor, PASSWORD)
    assert guesses == [400, 401]
    assert refused.status_code == 429  # the forged address did not move the guesser
    log = proxied.server.log_path.read_text()
    assert log.count("proxy headers from an untrusted peer were ignored") == 1


def test_a_clients_own_forwarded_host_and_port_do_not_change_the_links(proxied) -> None:
    """Issue 44 §6: nginx passed a client's X-Forwarded-Host and -Port on, and the server
    (HCSS_PROXY_HOPS=1) built links.csv on them: http://evil.example:444/p/..."""
    with proxied.visitor("127.0.0.71") as lab:
        assert _sign_in(lab, PASSWORD).status_code == 302
        csrf = csrf_token_of(lab.get("/console/").text)
        made = lab.post(
            "/console/participants", data={"csrf_token": csrf, "count": "1", "study": "demo"}
        )
        assert made.status_code in (302, 303), made.status_code
        with proxied.database.session_scope() as session:
            code = session.scalars(select(Participant.code).order_by(Participant.id.desc())).first()
        forged = {"X-Forwarded-Host": "evil.example", "X-Forwarded-Port": "444"}
        links = lab.get(f"/console/links.csv?codes={code}", headers=forged)
    assert links.status_code == 200, links.status_code
    assert "evil.example" not in links.text and ":444" not in links.text, links.text
    assert f"{proxied.nginx.url}/p/" in links.text, (proxied.nginx.url, links.text)


def test_sigterm_ends_the_open_streams_and_the_server_cleanly(proxied) -> None:
    """Last in the module: the server stops as a service manager stops it."""
    with proxied.database.command_scope() as session:
        participant = Participant(is_demo=True, study="demo")
        session.add(participant)
        session.flush()
        start_trial(session, participant, kind="trial", duration_s=600.0)
        token = participant.token
    process = proxied.server.process
    assert process is not None
    with proxied.visitor("127.0.4.1") as visitor:
        page = visitor.get(f"/live/{token}").raise_for_status().text
        stream_path = re.search(r"/api/live/[^\"']+/trials/\d+/stream", page)
        assert stream_path is not None
        with visitor.stream("GET", stream_path.group(0)) as stream:
            frames = stream.iter_bytes()
            next(frames)
            started = time.monotonic()
            process.send_signal(signal.SIGTERM)
            with pytest.raises((httpx.HTTPError, StopIteration)):
                while True:
                    next(frames)
        returncode = process.wait(timeout=20)
    stopped_s = time.monotonic() - started
    log = proxied.server.log_path.read_text()
    assert returncode == 0, log[-2000:]
    assert "hcss: stopped" in log and "still running" not in log
    assert stopped_s < 10
