"""Participant bots: walk the whole web study over HTTP, as a participant would.

A bot uses Flask's test client on an app whose live runner is driven by a
`ManualClock`: the bot moves the clock and lets the runner step, so a
20-minute trial takes a few seconds (time acceleration without waiting).
From the study file alone, independently of the study engine, it works out
which page must come next and asserts each page it reaches is that page;
then it posts what the page's stage declares (`Stage.bot_submissions`: the
answers it must refuse, then valid ones, as oTree's bots), answers MRT items,
supervises trials with a scripted operator policy (hcss.simulation.operators)
through the live JSON API and answers SA probes. Bot participants are
flagged `is_bot`, so their data are always set apart.
"""

from __future__ import annotations

import json
import re
import time
import uuid
from collections import defaultdict
from dataclasses import dataclass, field
from html.parser import HTMLParser
from typing import Any

import numpy as np
from flask import Flask
from sqlalchemy import select

from hcss.platform.live.idempotency import KEY_HEADER
from hcss.platform.live.service import LiveTrials
from hcss.platform.models import Participant, Trial
from hcss.platform.study.enrolment import assign_cell, current_enrolment
from hcss.platform.study.stage_protocol import Shown, SubmissionMustFail
from hcss.platform.study.stages import STAGES
from hcss.platform.study.studyfile import Study, load_study
from hcss.questionnaires import mrt, pages
from hcss.simulation import Display
from hcss.simulation.operators import InvestigateThenDecide

#: How often a bot asks again for a page that waits for the server's warm-up, and for how
#: long at most (a first compile on a busy machine has taken about 100 s).
WARMING_RECHECK_S = 1.0
WARMING_PATIENCE_S = 600.0


#: In-process: looks at a trial past its time limit before it is taken never to end.
OVERDUE_LOOKS = 50
#: Over HTTP: wall seconds a trial may stand at its limit, its end not yet written (the
#: bots' patience with a server that is away, http_load.RECONNECT_FOR_S).
OVERDUE_WAIT_S = 60.0


class BotError(AssertionError):
    """The bot reached a page it did not expect, or the platform refused it."""


class ManualClock:
    """Wall-clock seconds since the epoch that move only when told to.

    The one fake clock of the project (public testing API, docs/architecture.md):
    put on an app's database (`database.clock = ManualClock()`), it times the
    trials, the study's deadlines and every row's stamp alike.
    """

    def __init__(self, now: float | None = None) -> None:
        self.now = time.time() if now is None else now

    def __call__(self) -> float:
        return self.now


class PageParser(HTMLParser):
    """What a bot reads from a page: the stage marker, the form and its inputs."""

    def __init__(self) -> None:
        super().__init__()
        self.stage = self.step = ""
        self.action = ""
        self.hidden: dict[str, str] = {}
        self.radios: dict[str, list[str]] = defaultdict(list)
        self.checkboxes: list[str] = []
        self.mrt_item = ""
        self.interface: dict[str, str] = {}
        self.csrf = ""
        self.warming = False  # a training or trial page waiting for the server's warm-up
        self.alerts = 0  # messages shown with role="alert" (a refused answer's errors)
        self._noscript = 0

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = {k: v or "" for k, v in attrs}
        if tag == "noscript":
            self._noscript += 1
        if a.get("role") == "alert" and "hidden" not in a and not self._noscript:
            self.alerts += 1
        if tag == "main" and "data-stage" in a:
            self.stage, self.step = a["data-stage"], a.get("data-step", "")
        elif tag == "meta" and a.get("name") == "csrf-token":
            self.csrf = a.get("content", "")
        elif tag == "form" and a.get("id") == "stage-form":
            self.action = a.get("action", "")
        elif a.get("id") == "simulation-warming":
            self.warming = True
        elif tag == "div" and a.get("id") == "interface":
            self.interface = a
        elif tag == "div" and "data-item" in a:
            self.mrt_item = a["data-item"]
        elif tag == "input":
            kind, name = a.get("type"), a.get("name", "")
            if kind == "hidden":
                self.hidden[name] = a.get("value", "")
            elif kind == "radio":
                self.radios[name].append(a.get("value", ""))
            elif kind == "checkbox" and "disabled" not in a:
                self.checkboxes.append(a.get("value", ""))

    def handle_endtag(self, tag: str) -> None:
        if tag == "noscript":
            self._noscript -= 1


def refusal_of(html: str) -> str:
    """A refused page's reason (study/refused.html), as ": <reason>", else "": a bot's
    error then says why the platform refused it, not only the status."""
    found = re.search(r'id="refusal">([^<]*)<', html)
    return f": {found.group(1).strip()}" if found else ""


def parse_page(html: str) -> PageParser:
    parser = PageParser()
    parser.feed(html)
    return parser


def expected_pages(study: Study) -> list[tuple[str, str]]:
    """Every (stage, step) a participant passes through, from the study file alone."""
    intro = [f"page_{page.number}" for page in pages.introduction_pages()]
    settings = study.mrt
    mrt_steps = ["instructions"] + [f"practice_{n}" for n in range(1, settings.practice_items + 1)]
    for number in range(1, len(settings.part_items) + 1):
        mrt_steps += [f"break_{number - 1}" if number > 1 else "begin_1", f"part_{number}"]
        mrt_steps.append(f"done_{number}")  # or time_up_<n>, when the time ran out first
    steps = {
        "mental_rotation": mrt_steps,
        "introduction": intro,
        "training": ["ready", "run"],
        "trial": ["ready", "run"],
        "nasa_tlx": ["ratings", "comparisons"],
        "instruction_check": ["try_1"],  # a bot answers it rightly at once
    }
    names = (
        list(study.sequence.before)
        + list(study.sequence.per_model) * len(study.models)
        + list(study.sequence.after)
    )
    return [(name, step) for name in names for step in steps.get(name, ["form"])]


@dataclass
class BotReport:
    code: str
    pages: int = 0
    mrt_answers: int = 0
    requests: int = 0
    accepted: int = 0
    probes_answered: int = 0
    trials: list[int] = field(default_factory=list)


class ParticipantBot:
    """One bot participant walking the study from its personal link to the debrief."""

    def __init__(
        self,
        app: Flask | None,
        token: str,
        *,
        seed: int = 0,
        tick_s: float = 2.0,
        policy_every_s: float = 6.0,
        mrt_accuracy: float = 0.6,
        client: Any = None,
        code: str | None = None,
        look_every_wall_s: float = 0.2,
    ) -> None:
        """In-process (`app`, a test client, the bot moves the clock), or over HTTP
        (`client` from hcss.platform.bots.http_load, the server's own clock, `code` known)."""
        self.app = app
        self.token = token
        self.code = code
        self.rng = np.random.default_rng(seed)
        self.tick_s = tick_s  # trial seconds per look at the interface (in-process)
        self.look_every_wall_s = look_every_wall_s  # wall seconds per look (over HTTP)
        self.policy_every_s = policy_every_s
        self.mrt_accuracy = mrt_accuracy
        #: In-process: the app's live service, stepped on the bot's clock (None over HTTP).
        self.live: LiveTrials | None = None
        self.clock = ManualClock()
        self._accelerations: dict[int, float] = {}
        self.study: Study | None = None  # the study `run` walks
        if client is not None:
            self.client = client
            return
        assert app is not None
        self.client = app.test_client()
        self.live = app.extensions["hcss_live"]
        clock = app.extensions["hcss_db"].clock
        if not isinstance(clock, ManualClock):
            raise BotError("bots need the app's database on a ManualClock (use bot_app)")
        self.clock = clock

    # --- HTTP ------------------------------------------------------------------------

    def get(self, url: str) -> tuple[str, str]:
        """GET, following redirects; returns (final path, html)."""
        response = self.client.get(url, follow_redirects=True)
        if response.status_code != 200:
            raise BotError(f"GET {url} answered {response.status_code}")
        return response.request.path, response.get_data(as_text=True)

    def post_form(self, page: PageParser, fields: dict[str, Any]) -> str:
        body = dict(page.hidden) | fields
        response = self.client.post(page.action, data=body, follow_redirects=True)
        if response.status_code != 200:
            raise BotError(
                f"POST {page.action} answered {response.status_code}"
                f"{refusal_of(response.get_data(as_text=True))}"
            )
        return response.get_data(as_text=True)

    # --- the walk --------------------------------------------------------------------

    def run(self, study: Study) -> BotReport:
        self.study = study
        code = self.code
        if code is None and self.app is not None:
            with self.app.app_context():
                from hcss.platform.db import database

                with database().session_scope() as session:
                    code = session.scalar(
                        select(Participant.code).where(Participant.token == self.token)
                    )
        report = BotReport(code=code or "?")
        plan = expected_pages(study)
        _, html = self.get(f"/p/{self.token}")
        position = 0
        while True:
            page = parse_page(html)
            if page.interface:
                stage, step = plan[position]
                if step != "run":
                    raise BotError(f"expected {stage}/{step}, reached the Collective Interface")
                html = self.supervise(page, stage, report)
                position += 1
                report.pages += 1
                continue
            if page.stage == "debrief" and position == len(plan) - 1:
                report.pages += 1
                return report
            if page.stage == "mental_rotation" and page.step.startswith("time_up_"):
                # Shown only when a part's time ran out (over HTTP, under load or
                # across a restart), so it is not in the plan: press its Continue. A
                # part that ran out while the server was down was never seen at all.
                # It stands in for the part's "done" page, which a part that ran out never shows.
                part = ("mental_rotation", page.step.replace("time_up_", "part_"))
                done = ("mental_rotation", page.step.replace("time_up_", "done_"))
                if position < len(plan) and plan[position] == part:
                    position += 1
                if position < len(plan) and plan[position] == done:
                    position += 1
                html = self.post_form(page, {})
                report.pages += 1
                continue
            if self._ran_out_unseen(plan, position, page):
                position += 1
                continue
            if position >= len(plan) or (page.stage, page.step) != plan[position]:
                wanted = plan[position] if position < len(plan) else "the end"
                raise BotError(f"expected {wanted}, reached {page.stage}/{page.step}")
            if page.warming:
                html = self.wait_for_warm_up()
                continue
            html, finished = self.act(page, report)
            if finished:
                position += 1
                report.pages += 1

    def wait_for_warm_up(self) -> str:
        """Ask for the page again until the server's simulation is ready, as the page's
        own refresh does; the stage's Start is refused until then."""
        deadline = time.monotonic() + WARMING_PATIENCE_S
        while time.monotonic() < deadline:
            time.sleep(WARMING_RECHECK_S)
            html = self.get(f"/p/{self.token}/stage")[1]
            if not parse_page(html).warming:
                return html
        raise BotError(f"the server's simulation was not ready after {WARMING_PATIENCE_S:g} s")

    def _ran_out_unseen(self, plan: list[tuple[str, str]], position: int, page: PageParser) -> bool:
        """Over HTTP: the trial of `plan[position]` ended before its page reached the bot.

        When the answer to Ready is lost in a server restart, the trial runs out
        while the bot waits for the server to come back (training lasts seconds
        at the load tool's accelerations); the next page is then the stage
        after it, as a participant reloading would find.
        """
        return (
            self.live is None
            and position + 1 < len(plan)
            and plan[position][1] == "run"
            and (page.stage, page.step) == plan[position + 1]
        )

    def act(self, page: PageParser, report: BotReport) -> tuple[str, bool]:
        """Answer the page; True when that ends the step (MRT parts take many answers)."""
        stage, step = page.stage, page.step
        if stage == "mental_rotation" and page.mrt_item:
            try:
                html = self.post_form(page, {"chosen": self.mrt_choice(page.mrt_item)})
            except BotError as refusal:
                # Over HTTP the part's time can run out under load (409, as for a slow
                # participant); the server has moved on, and so does the bot.
                if self.live is not None or "answered 409" not in str(refusal):
                    raise
                html = self.get(f"/p/{self.token}/stage")[1]
            report.mrt_answers += page.hidden.get("action") == "answer"
            after = parse_page(html)
            done = (after.stage, after.step) != (stage, step)
            return html, done
        shown = Shown(step, self.rng, page.radios, self.walked_study())
        html = ""
        for submission in STAGES[stage].bot_submissions(shown):
            html = self.post_form(page, dict(submission.fields))
            if isinstance(submission, SubmissionMustFail):
                again = parse_page(html)
                if (again.stage, again.step) != (stage, step) or not again.alerts:
                    raise BotError(f"{stage}/{step} took {dict(submission.fields)}: must refuse")
                page = again  # the form shown again, with its errors
        return html, True

    def walked_study(self) -> Study | None:
        """The study `run` walks; for a bot driven page by page in-process, its participant's."""
        if self.study is None and self.app is not None:
            with self.app.app_context():
                from hcss.platform.db import database

                with database().session_scope() as session:
                    participant_id = session.scalar(
                        select(Participant.id).where(Participant.token == self.token)
                    )
                    enrolment = (
                        None
                        if participant_id is None
                        else current_enrolment(session, participant_id)
                    )
                    if enrolment is not None:
                        self.study = load_study(enrolment.study)
        return self.study

    def mrt_choice(self, key: str) -> list[str]:
        item = next(i for i in (*mrt.item_bank(), *mrt.practice_items()) if i.key == key)
        if self.rng.random() < self.mrt_accuracy:
            return [str(i) for i in sorted(item.correct)]
        return [str(i) for i in sorted(self.rng.choice(4, size=2, replace=False))]

    # --- a live trial ------------------------------------------------------------------

    def supervise(self, page: PageParser, stage: str, report: BotReport) -> str:
        """Run the trial to its end: look, request, answer probes; then press Continue."""
        stream = re.search(r"/trials/(\d+)/", page.interface["data-stream-url"])
        if stream is None:
            raise BotError(f"{stage}: the trial page names no stream")
        trial_id = int(stream.group(1))
        api = f"/api/live/{self.token}/trials/{trial_id}"

        def command(path: str, body: dict[str, Any]) -> dict[str, Any]:
            """POST a command as the page does: its CSRF token and a fresh Idempotency-Key."""
            headers = {"X-CSRFToken": page.csrf, KEY_HEADER: uuid.uuid4().hex}
            return self._ok(self.client.post(api + path, json=body, headers=headers))

        report.trials.append(trial_id)
        policy = InvestigateThenDecide(abandon_below=0.3)
        next_policy = 0.0
        overdue_looks = 0
        overdue_since: float | None = None
        while True:
            state = self.client.get(api + "/state")
            if state.status_code == 409:  # the runner has let go of an ended trial
                break
            frame = json.loads(state.get_data(as_text=True))
            if frame["trial"]["kind"] != stage:
                raise BotError(
                    f"expected a {stage}, the interface shows a {frame['trial']['kind']}"
                )
            if frame["trial"]["status"] == "ended":
                break
            clock = frame["trial"]["clock_s"]
            if clock >= frame["trial"]["duration_s"]:
                overdue_looks += 1
                overdue_since = overdue_since or time.monotonic()
            if self._never_ends(overdue_looks, overdue_since):
                raise BotError(f"trial {trial_id} is still running after its time limit")
            probe = frame.get("probe")
            if probe and probe["phase"] == "ready":
                command(f"/probes/{probe['id']}/ready", {})
            elif probe:
                answer = str(self.rng.choice(probe["choices"]))
                command(f"/probes/{probe['id']}/answer", {"answer": answer})
                report.probes_answered += 1
            if clock >= next_policy:
                next_policy = clock + self.policy_every_s
                for request in policy.commands(Display.from_json(frame["view"]))[:3]:
                    outcome = command("/requests", request.to_json())
                    report.requests += 1
                    report.accepted += bool(outcome.get("accepted"))
                if frame["view"]["collectives"]:
                    hub = int(self.rng.integers(len(frame["view"]["collectives"])))
                    click = {"kind": "collective", "collective": hub, "button": "right"}
                    command("/observations", click)
            self._next_look(frame)
        continue_url = page.interface.get("data-continue-url")
        if not continue_url:
            raise BotError("the trial page offers no way on to the next stage")
        return self.get(continue_url)[1]

    def _never_ends(self, overdue_looks: int, overdue_since: float | None) -> bool:
        """Whether a trial past its time limit and still running never ends (a finding).

        In-process the bot steps the runner itself: 50 looks past the limit are plenty.
        Over HTTP a trial stands at its limit, running, while its end cannot be written
        (the database away or read-only, its link stalled) and ends once it can, as the
        page waits for it: the bot waits as long as for a server that is away.
        """
        if self.live is not None:
            return overdue_looks > OVERDUE_LOOKS
        return overdue_since is not None and time.monotonic() - overdue_since > OVERDUE_WAIT_S

    def _next_look(self, frame: dict[str, Any]) -> None:
        """In-process: move the clock and let the runner step. Over HTTP: wait."""
        if self.live is None:
            time.sleep(self.look_every_wall_s)
            return
        self.clock.now += self.tick_s / self._acceleration(frame["trial"]["id"])
        self.live.catch_up()

    def _acceleration(self, trial_id: int) -> float:
        """The trial's time acceleration, from its row (read once per trial)."""
        if trial_id not in self._accelerations:
            assert self.app is not None
            with self.app.extensions["hcss_db"].session_scope() as session:
                trial = session.get(Trial, trial_id)
                self._accelerations[trial_id] = 1.0 if trial is None else trial.time_acceleration
        return self._accelerations[trial_id]

    @staticmethod
    def _ok(response: Any) -> dict[str, Any]:
        if response.status_code >= 400 and response.status_code != 409:
            raise BotError(
                f"live API answered {response.status_code}: {response.get_data(as_text=True)}"
            )
        return response.get_json(silent=True) or {}


def bot_app(database_url: str, study: str, **config: Any) -> Flask:
    """An app for bots: the named study, no runner thread, a clock the bots move."""
    from hcss.platform.app import create_app

    study_file = load_study(study)
    app = create_app(
        {
            "DATABASE_URL": database_url,
            "STUDY": study,
            "LIVE_RUNNER": False,
            "TIME_ACCELERATION": study_file.timing.max_time_acceleration,
            **config,
        }
    )
    app.extensions["hcss_db"].clock = ManualClock()
    return app


def run_bots(app: Flask, n: int, *, seed: int = 0, progress: Any = None) -> list[BotReport]:
    """Create `n` bot participants, enrol each, and walk each through the whole study."""
    from hcss.platform.db import database

    study = load_study(app.config["STUDY"])
    reports = []
    for number in range(n):
        with app.app_context(), database().session_scope() as session:
            participant = Participant(is_bot=True)
            session.add(participant)
            session.flush()
            assign_cell(session, participant)
            token = participant.token
        reports.append(ParticipantBot(app, token, seed=seed + number).run(study))
        if progress is not None:
            progress(reports[-1])
    return reports
