"""A live trial as a test drives it: a participant, a browser-like client and the fake clock.

Live trials run on a fake clock: `TrialHandle.run_to(seconds)` moves the wall clock and
lets the runner step, so a 20-minute trial takes a second (the `make_trial` fixture of
tests/platform/conftest.py starts one).
"""

from __future__ import annotations

import re
import uuid
from dataclasses import dataclass
from typing import Any

import pytest
from flask import Flask
from flask.testing import FlaskClient

from hcss.platform.live.runner import Runner
from hcss.platform.study.studyfile import load_study

#: The original study's trial length (`timing.trial_s`), for trials a test starts directly.
STUDY = load_study("original")
STUDY_TRIAL_S = STUDY.timing.trial_s


def csrf_token_of(html: str) -> str:
    match = re.search(r'<meta name="csrf-token" content="([^"]+)"', html)
    assert match, "page has no csrf-token meta tag"
    return match.group(1)


@dataclass
class TrialHandle:
    """A participant with a live trial, and a browser-like client for it."""

    app: Flask
    client: FlaskClient
    token: str
    trial_id: int
    started_epoch: float
    acceleration: float
    csrf: str = ""

    @property
    def runner(self) -> Runner:
        return self.app.extensions["hcss_runner"]

    @property
    def api(self) -> str:
        return f"/api/live/{self.token}/trials/{self.trial_id}"

    def open_page(self) -> None:
        """GET the trial page, as a browser does, and keep its CSRF token."""
        page = self.client.get(f"/live/{self.token}")
        assert page.status_code == 200
        self.csrf = csrf_token_of(page.get_data(as_text=True))

    def run_to(self, trial_seconds: float) -> None:
        """Move the wall clock to this trial time and let the runner catch up."""
        self.runner.clock.now = self.started_epoch + trial_seconds / self.acceleration
        self.runner.tick()

    def post(self, path: str, body: Any) -> Any:
        """POST a command as the page does: its CSRF token and a fresh Idempotency-Key."""
        return self.client.post(
            self.api + path,
            json=body,
            headers={"X-CSRFToken": self.csrf, "Idempotency-Key": uuid.uuid4().hex},
        )

    def state(self) -> dict[str, Any]:
        response = self.client.get(self.api + "/state")
        assert response.status_code == 200, response.get_data(as_text=True)
        return response.get_json()

    def live(self):
        return self.runner.host(self.trial_id)


def investigate_request(trial):
    trial.run_to(60)
    target = next(t for t in trial.state()["view"]["targets"] if 0 in t["in_range_of"])
    return {"kind": "investigate", "collective": 0, "target": target["id"]}


def until_probe(trial, start: float, level: int | None = None):
    """Run on until a probe (of `level`) is on screen; return it and the state then."""
    second = start
    while second < trial.live().duration_s:
        second += 1
        trial.run_to(second)
        state = trial.state()
        probe = state["probe"]
        if probe and (level is None or probe["level"] == level):
            return probe, state, second
        if probe:  # another level: answer it so the next can come
            trial.post(f"/probes/{probe['id']}/ready", {})
            choice = trial.state()["probe"]["choices"][0]
            trial.post(f"/probes/{probe['id']}/answer", {"answer": choice})
    pytest.fail(f"no level-{level} probe in the trial")
