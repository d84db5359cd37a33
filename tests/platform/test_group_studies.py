"""Every process of a group serves the same study files (issue 29, several hosts).

`/join` goes to any process and each enrolment keeps its study file's digest,
so a process starting with another file for a study the group serves would
enrol participants under another version. It refuses to serve instead, with
a message that says which file and what to do.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys

import pytest
from sqlalchemy import update

from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import GroupStudy
from hcss.platform.serving.workers import (
    MEMBER_GONE_S,
    GroupRefused,
    require_same_studies,
    served_studies,
)

OTHER_DEMO = "0" * 64  # the digest of a demo study file that is not this checkout's


@pytest.fixture
def group_database(database_url: str):
    if not database_url.startswith("postgresql"):
        pytest.skip("a process group runs on PostgreSQL")
    upgrade_database(database_url)
    database = Database(database_url)
    yield database
    database.engine.dispose()


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def test_a_process_with_another_study_file_than_the_group_refuses_to_serve(
    group_database: Database, tmp_path
) -> None:
    """Process a of the group serves another demo file; `hcss serve --cluster` with this
    checkout's demo file exits with the reason instead of serving."""
    require_same_studies(
        group_database, "10.0.0.1:8000/a", {**served_studies(), "demo": OTHER_DEMO}
    )
    env = {
        **os.environ,
        "DATABASE_URL": group_database.url,
        "HCSS_INSTANCE_PATH": str(tmp_path / "instance"),
        "HCSS_SECRET_KEY": "group-studies",
    }
    command = [sys.executable, "-m", "hcss.platform", "serve", "--cluster"]
    command += ["--host", "127.0.0.1", "--port", str(_free_port())]
    try:
        ended = subprocess.run(command, env=env, capture_output=True, text=True, timeout=60)
    except subprocess.TimeoutExpired:
        pytest.fail("the process served the group with another demo study file")
    assert ended.returncode != 0
    assert "study demo: this process's file" in ended.stderr, ended.stderr
    assert "10.0.0.1:8000/a" in ended.stderr and "same study files" in ended.stderr


def test_the_same_files_are_served_and_a_gone_members_file_binds_nobody(
    group_database: Database,
) -> None:
    ours = served_studies()
    require_same_studies(group_database, "a:1/x", ours)
    require_same_studies(group_database, "b:2/y", ours)  # the same files: served
    with pytest.raises(GroupRefused, match="study demo"):
        require_same_studies(group_database, "c:3/z", {**ours, "demo": OTHER_DEMO})
    with group_database.session_scope() as session:  # a and b stopped long ago
        session.execute(
            update(GroupStudy).values(seen_epoch=GroupStudy.seen_epoch - MEMBER_GONE_S - 1)
        )
    require_same_studies(group_database, "c:3/z", {**ours, "demo": OTHER_DEMO})
    with group_database.session_scope() as session:
        assert session.get_one(GroupStudy, "demo").digest == OTHER_DEMO
