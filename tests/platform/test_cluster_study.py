"""A whole study on two server processes behind nginx, one PostgreSQL database (issue 20, part 5).

The processes listen on different loopback addresses (127.0.0.2, 127.0.0.3),
as processes on two hosts would, and are `hcss serve --cluster` ones behind
the nginx configuration `hcss deploy nginx` writes. Counterbalancing must
stay exact when both assign cells at once, and a study walked by HTTP bots
must survive a kill -9 of the process that hosts most of its live trials.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import httpx
import pytest

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.localserver import LocalNginx, LocalServer
from hcss.platform.models import Participant
from hcss.platform.study.enrolment import cell_counts
from hcss.platform.study.studyfile import load_study
from tests.platform.test_failover import skip_unless_group

#: What a laptop's browser measures and posts with the study link's Start.
LAPTOP = {"width": "1366", "height": "768", "mobile": "0", "missing": ""}
HIDDEN = re.compile(r'<input type="hidden" name="([^"]+)" value="([^"]*)"')


@pytest.fixture
def group_database_url(database_url: str) -> str:
    return skip_unless_group(database_url)


@contextmanager
def _two_processes(
    database_url: str, workdir: Path, extra_env: dict[str, str] | None = None
) -> Iterator[tuple[list[LocalServer], LocalNginx]]:
    """Two `--cluster` processes on two addresses behind nginx, as docs/operations.md deploys."""
    servers = [
        LocalServer(
            database_url,
            workdir / name,
            snapshot_interval_s=1.0,
            serve_args=["--cluster"],
            host=address,
            extra_env={"HCSS_PROXY_HOPS": "1", **(extra_env or {})},
        )
        for name, address in (("a", "127.0.0.2"), ("b", "127.0.0.3"))
    ]
    nginx = LocalNginx([f"{s.host}:{s.port}" for s in servers], workdir / "nginx")
    try:
        for server in servers:
            server.start(timeout_s=120)  # a first start compiles the simulation
        nginx.start()
        yield servers, nginx
    finally:
        nginx.stop()
        for server in servers:
            server.stop()


@pytest.mark.slow
def test_participants_arriving_at_once_on_two_processes_fill_the_cells_exactly(
    group_database_url: str, tmp_path
) -> None:
    """Six waves of 8 first visits at once, half by the study link, half by created links.

    The single-process tests (test_study_counterbalancing.py,
    test_online_recruitment.py) show the assignment lock orders the threads
    of one process; a lock that only one process's threads shared would not
    order two. Through nginx the study link's Start (no token) goes
    round-robin to both processes and a personal link to the process its
    token hashes to, so both read the cell counts and enrol at the same
    moments. The counts are checked after every wave: a wave fills each of
    the 8 cells once, and a collision between the processes shows at once,
    where after all 48 a later arrival could have evened it out.
    """
    database_url = group_database_url
    upgrade_database(database_url)
    database = Database(database_url)
    study = load_study("demo")
    waves, cells = 6, len(study.cells)
    with database.session_scope() as session:
        created = [Participant(study="demo") for _ in range(waves * cells // 2)]
        session.add_all(created)
        session.flush()
        tokens = [p.token for p in created]
    answers: list[int] = []
    errors: list[BaseException] = []
    after_each_wave = []
    # Every Start comes from nginx's address: no per-client limit on enrolment here.
    with _two_processes(database_url, tmp_path, {"HCSS_JOIN_PER_CLIENT": "0"}) as (_, nginx):

        def join(client: httpx.Client, barrier: threading.Barrier, number: int) -> httpx.Response:
            """The study link's first page (its form, its session cookie), then Start at once."""
            query = {"PROLIFIC_PID": f"cluster-{number:03d}", "STUDY_ID": "S1", "SESSION_ID": "X"}
            page = client.get("/join/demo", params=query)
            assert page.status_code == 200, page.text
            barrier.wait(timeout=60)
            return client.post("/join/demo", data=dict(HIDDEN.findall(page.text)) | LAPTOP)

        def enter(client: httpx.Client, barrier: threading.Barrier, token: str) -> httpx.Response:
            """A created participant's personal link, opened for the first time."""
            barrier.wait(timeout=60)
            return client.get(f"/p/{token}")

        def arrive(send, barrier, argument) -> None:  # type: ignore[no-untyped-def]
            with httpx.Client(base_url=nginx.url, timeout=60) as client:
                try:
                    answers.append(send(client, barrier, argument).status_code)
                except BaseException as error:  # noqa: BLE001 - reported below
                    errors.append(error)

        for wave in range(waves):
            barrier = threading.Barrier(cells)
            half = cells // 2
            visits = [(join, barrier, wave * half + n) for n in range(half)]
            visits += [(enter, barrier, t) for t in tokens[wave * half : (wave + 1) * half]]
            threads = [threading.Thread(target=arrive, args=visit) for visit in visits]
            for thread in threads:
                thread.start()
            for thread in threads:
                thread.join(timeout=120)
            with database.session_scope() as session:
                after_each_wave.append(dict(sorted(cell_counts(session, study, "real").items())))
    database.engine.dispose()
    assert not errors, errors
    assert answers == [302] * waves * cells, answers  # each enrolled, led on to its link
    print(f"cells after each wave of {cells} on two processes: {after_each_wave}")
    assert after_each_wave == [
        {cell.number: wave for cell in study.cells} for wave in range(1, waves + 1)
    ]
