"""`make run PORT= STUDY=`, `hcss demo-trial` on the server's port, event lines on the terminal."""

from __future__ import annotations

import json
import re
import subprocess
import urllib.request
from pathlib import Path

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.platform.cli import upgrade_database
from hcss.platform.db import Database
from hcss.platform.models import Participant
from hcss.platform.serving.localserver import LocalServer

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def instance(tmp_path, monkeypatch) -> tuple[Path, str]:
    url = f"sqlite:///{tmp_path / 'serving.sqlite3'}"
    upgrade_database(url)
    monkeypatch.setenv("DATABASE_URL", url)
    monkeypatch.setenv("HCSS_INSTANCE_PATH", str(tmp_path / "instance"))
    monkeypatch.delenv("HCSS_STUDY", raising=False)
    return tmp_path / "instance", url


def _demo_trial(*arguments: str) -> tuple[str, str]:
    result = CliRunner().invoke(main, ["demo-trial", *arguments])
    assert result.exit_code == 0, result.output
    summary, link = result.output.strip().splitlines()[-2:]
    return summary, link


def test_make_run_passes_port_and_study_to_the_server() -> None:
    dry = subprocess.run(
        ["make", "-n", "run", "PORT=8123", "STUDY=demo"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=True,
    )
    assert re.search(r"hcss serve --port 8123 --study demo$", dry.stdout, re.MULTILINE)


def test_demo_trial_links_to_the_port_the_server_wrote(instance) -> None:
    folder, _ = instance
    summary, link = _demo_trial()  # no server has run here: the default port
    assert re.fullmatch(r"http://127\.0\.0\.1:5000/live/[A-Za-z0-9_-]{32}", link)
    assert "study original" in summary and "20 min" in summary
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "serving.json").write_text(
        json.dumps({"url": "http://127.0.0.1:8123", "study": "demo"})
    )
    summary, link = _demo_trial()
    assert link.startswith("http://127.0.0.1:8123/live/") and "2 min, study demo" in summary
    _, link = _demo_trial("--port", "9001")
    assert link.startswith("http://127.0.0.1:9001/live/")
    _, link = _demo_trial("--base-url", "https://lab.example.org/")
    assert link.startswith("https://lab.example.org/live/")
    summary, _ = _demo_trial("--training", "--study", "original")
    assert "training" in summary and "5 min, study original" in summary


@pytest.mark.parametrize(
    "arguments",
    [["--study", "nope"], ["--study", "../original"], ["--port", "0"], ["--port", "70000"]],
)
def test_demo_trial_refuses_a_bad_study_or_port_without_a_traceback(instance, arguments) -> None:
    result = CliRunner().invoke(main, ["demo-trial", *arguments])
    assert result.exit_code == 2 and "Traceback" not in result.output


@pytest.mark.slow  # starts a real server (about 3 s)
def test_the_server_prints_participant_events_and_enrols_in_its_study(instance) -> None:
    folder, url = instance
    database = Database(url)
    with database.session_scope() as session:
        participant = Participant()  # no study chosen: the server's STUDY applies
        session.add(participant)
        session.flush()
        token, code = participant.token, participant.code
    database.engine.dispose()
    with LocalServer(url, folder, extra_env={"HCSS_STUDY": "demo"}) as server:
        serving = json.loads((folder / "serving.json").read_text())
        assert serving == {"url": server.url, "study": "demo"}
        with urllib.request.urlopen(f"{server.url}/p/{token}") as response:
            assert response.status == 200
        _, link = _demo_trial()
        assert link.startswith(f"{server.url}/live/")
        with urllib.request.urlopen(link) as response:
            assert response.status == 200
    log = server.log_path.read_text()
    assert re.search(rf"^\d\d:\d\d:\d\d {code} enrolled: study demo, cell \d+ ", log, re.M), log
    assert re.search(rf"^\d\d:\d\d:\d\d {code} stage 1 consent: entered$", log, re.M), log
    assert log.count(f"{code} stage 1 consent: entered") == 1, log  # once, not twice
    assert token not in log


def test_serve_refuses_an_unknown_study_before_listening(instance) -> None:
    result = CliRunner().invoke(main, ["serve", "--port", "1", "--study", "nope"])
    assert result.exit_code == 2 and "no study file nope.toml" in result.output
    assert "Traceback" not in result.output


@pytest.mark.slow  # starts two real servers (about 6 s)
def test_demo_trial_on_a_port_takes_the_study_of_the_server_on_that_port(instance) -> None:
    """Two servers, the demo on one and the protocol on the other started last: a demo
    trial for the first one's port is the demo's (2 minutes), not the last server's."""
    folder, url = instance
    with (
        LocalServer(url, folder, extra_env={"HCSS_STUDY": "demo"}) as demo,
        LocalServer(url, folder, extra_env={"HCSS_STUDY": "original"}) as protocol,
    ):
        summary, link = _demo_trial("--port", str(demo.port))
        assert link.startswith(f"{demo.url}/live/")
        assert "2 min, study demo" in summary
        summary, link = _demo_trial("--port", str(protocol.port))
        assert link.startswith(f"{protocol.url}/live/")
        assert "20 min, study original" in summary
