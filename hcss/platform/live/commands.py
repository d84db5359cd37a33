"""The live service's participant commands: the JSON API's only way into a running trial.

The participant's API (hcss.platform.live.api) parses HTTP and passes what it
read, the trial's id, the JSON body, the idempotency key, as plain values; it
never holds a `RunningTrial`, its lock or a session of the trial log. Each
command here finds the trial (hosted here, taken over now, or
`HostedElsewhere`: a 503 the page retries and a proxy sends to the next
process), checks the body against the trial's ranges
(hcss.platform.live.validation), and carries the action out under the
trial's lock in one unit of work (hcss.platform.live.actions), so the
checks, the lock and the writes stay inside live.

That the token owns the trial is the caller's check (`access.require_owner`,
which answers 404 for another participant's trial before anything here
runs; `holds_for` answers it in memory for a trial held here). The console's and the study flow's commands are in
hcss.platform.live.service; the participant's are a module of their own so
that neither grows past a screenful. The import-linter contract "The console
reaches live trials through the live service" (pyproject.toml) keeps the API
on this side of the trial.
"""

from __future__ import annotations

import hmac
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from sqlalchemy import select

from hcss.platform.db import Database
from hcss.platform.live import actions, validation
from hcss.platform.live.actions import ActionError
from hcss.platform.live.command_keys import Answer, once
from hcss.platform.live.frames import ended_stream, event_stream
from hcss.platform.live.runner import Runner
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.stream_slots import StreamSlots
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.live.trials import end_reason
from hcss.platform.models import Participant, StudyEnrolment, Trial

__all__ = [
    "ActionError",
    "Answer",
    "Stream",
    "frame",
    "holds_for",
    "observe",
    "open_stream",
    "probe_answer",
    "probe_ready",
    "submit_request",
]


def holds_for(runner: Runner, token: str, trial_id: int) -> bool:
    """Whether this process holds the trial in memory for this token; False: ask the database.

    The live API's looks and commands come several times a second per trial;
    checking a held trial's owner in memory spares each of them a query and a
    transaction. A trial not held, or held for another token, goes the
    database's way, so every answer (404, 409) is the same either way.
    """
    live = runner.loaded(trial_id)
    return live is not None and hmac.compare_digest(live.participant_token.encode(), token.encode())


def _running(runner: Runner, trial_id: int) -> RunningTrial:
    """The trial hosted here for the participant's request (which asks it back if another
    process holds it: nginx sends this participant here)."""
    live = runner.host(trial_id, participant=True)
    if live is None:
        raise ActionError("the trial has ended", 409, "ended")
    return live


def frame(runner: Runner, trial_id: int) -> str:
    """One frame of the stream as JSON text, for bots and scripts that poll."""
    live = _running(runner, trial_id)
    with live.lock:
        text, _ = live.frame(runner.clock(), 0)
    return text


def _answered(
    database: Database,
    runner: Runner,
    trial_id: int,
    key: KeyedCommand | None,
    status: int,
    act: Callable[[KeyedCommand | None], dict[str, Any]],
) -> Answer:
    """`act`'s answer with `status`; with a key, carried out once (`command_keys.once`).

    The caller (the API's view) has read the request already: only `act`, the
    service's own code, runs under the trial's lock, never a Flask view.
    Without a key an `ActionError` goes to the caller (the API answers it).
    """
    with runner.commanding(trial_id):  # not handed to another process meanwhile
        if key is None:
            return Answer(status, act(None))

        def carry_out(keyed: KeyedCommand) -> Answer:
            try:
                return Answer(status, act(keyed))
            except ActionError as error:
                return Answer(error.status, {"error": error.code, "message": error.message})

        return once(database, runner, key, carry_out)


def submit_request(
    database: Database, runner: Runner, trial_id: int, body: Any, key: KeyedCommand | None
) -> Answer:
    """The request in the POST body, checked and applied; the answer the page gets."""

    def act(keyed: KeyedCommand | None) -> dict[str, Any]:
        live = _running(runner, trial_id)
        with database.session_scope() as session:  # read-only: back in the pool first
            command, selections = validation.parse_request(body, live, session, trial_id)
        return actions.submit_request(database, live, command, selections, key=keyed)

    return _answered(database, runner, trial_id, key, 200, act)


def observe(
    database: Database, runner: Runner, trial_id: int, body: Any, key: KeyedCommand | None
) -> Answer:
    """A click on the map, checked and logged; the answer is the observation's id (201)."""

    def act(keyed: KeyedCommand | None) -> dict[str, Any]:
        live = _running(runner, trial_id)
        kind, collective, target, button = validation.parse_observation(body, live)
        return actions.record_observation(
            database,
            live,
            kind=kind,
            collective=collective,
            target=target,
            button=button,
            key=keyed,
        )

    return _answered(database, runner, trial_id, key, 201, act)


def probe_ready(
    database: Database, runner: Runner, trial_id: int, probe_id: int, key: KeyedCommand | None
) -> Answer:
    """The Ready press on the open probe, timed by the runner's clock."""

    def act(keyed: KeyedCommand | None) -> dict[str, Any]:
        live = _running(runner, trial_id)
        return actions.probe_ready(database, live, probe_id, now=runner.clock(), key=keyed)

    return _answered(database, runner, trial_id, key, 200, act)


def probe_answer(
    database: Database,
    runner: Runner,
    trial_id: int,
    probe_id: int,
    body: Any,
    key: KeyedCommand | None,
) -> Answer:
    """The answer in the POST body to the open probe, timed by the runner's clock."""

    def act(keyed: KeyedCommand | None) -> dict[str, Any]:
        live = _running(runner, trial_id)
        answer = validation.parse_answer(body)
        return actions.probe_answer(database, live, probe_id, answer, now=runner.clock(), key=keyed)

    return _answered(database, runner, trial_id, key, 200, act)


@dataclass(frozen=True)
class Stream:
    """A trial's Server-Sent Events: its frames, and what to do once the connection closes."""

    frames: Iterator[str]
    closed: Callable[[], None] = lambda: None


def open_stream(
    database: Database,
    runner: Runner,
    slots: StreamSlots,
    trial: Trial,
    *,
    token: str,
    client: str,
    after_seq: int,
    interval_s: float,
    max_s: float,
) -> Stream:
    """The trial's stream from message `after_seq` on; one closing frame if it is not live.

    A live trial's stream takes one of the server's `slots` (503 "busy" when
    none is free, released when the connection closes) and wakes the link's
    older stream, which sees it is superseded and hands over.
    """
    live = runner.host(trial.id, participant=True)
    if live is None:
        with database.session_scope() as session:
            reason = end_reason(session, trial.id)
        return Stream(ended_stream(trial.id, trial.duration_s, reason))
    ticket = slots.acquire(token, client, _study_of(database, trial.participant_id))
    if ticket is None:
        raise ActionError(
            "the server has as many live streams as it can hold; retrying shortly",
            503,
            "busy",
        )
    with live.changed:
        live.changed.notify_all()
    frames = event_stream(
        live,
        after_seq=after_seq,
        interval_s=interval_s,
        max_s=max_s,
        clock=runner.clock,
        superseded=lambda: slots.superseded(ticket),
    )
    return Stream(frames, lambda: slots.release(ticket))


def _study_of(database: Database, participant_id: int) -> str:
    """The study the participant is enrolled in (else invited to; "" for neither), for the
    stream's per-study share; a read-only unit of work before the stream starts."""
    with database.session_scope() as session:
        enrolled = session.scalar(
            select(StudyEnrolment.study)
            .where(StudyEnrolment.participant_id == participant_id)
            .order_by(StudyEnrolment.id.desc())
            .limit(1)
        )
        invited = None
        if enrolled is None:
            invited = session.scalar(
                select(Participant.study).where(Participant.id == participant_id)
            )
    return enrolled or invited or ""
