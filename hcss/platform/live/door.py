"""The live service's one door: every command for a running trial, a value in, an answer out.

The participant's request, map click, probe Ready and probe answer, and the
experimenter's pause, resume and abort, are each a small frozen value
(`SubmitRequest`, `Observe`, `ProbeReady`, `ProbeAnswer`, `Control`), and
`carry_out` is the one function that takes them. For every command it

1. finds the trial: hosted here, claimed and rebuilt now, or hosted by
   another process (the participant's command: `HostedElsewhere`, a 503 the
   page retries and a proxy sends to the next process; the console's: a
   `TrialOrder` that the host carries out through this same door);
2. takes the trial's lock, and with an idempotency key looks the key up
   first: a repeat, even one racing the first, waits for the lock and is
   answered from the stored row without touching the trial again, and a key
   sent with another command is refused (422);
3. checks the trial's state under that lock (moved, ended, paused, the probe
   still open; a console pause of a paused trial writes nothing);
4. applies the command and writes it in one fenced unit of work (the
   participant's: hcss.platform.live.actions; the console's:
   hcss.platform.live.control), the key stored with what it records;
5. answers with an `Answer`: HTTP status and JSON body, which is what the
   API sends and what a key's repeat gets back.

A refusal that recorded nothing (bad JSON, a closed probe, a paused trial)
is stored with its key in a transaction of its own, so a repeat gets the
same refusal even after the trial has moved on; if that write is lost, the
retry is merely checked afresh, which records nothing twice. A 5xx answer is
not stored: the client may try again with the same key.

Why the key of a command that records something is written by the action,
in the transaction that records the command: were it written afterwards, a
server killed (or a write failing) between the two commits would leave the
command without its key, and the client's retry would record it twice.

The callers parse HTTP (hcss.platform.live.api, hcss.platform.live.idempotency)
or read the console's form (hcss.platform.live.service for the console) and
pass plain values; no Flask view runs under the trial's lock.
"""

from __future__ import annotations

from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

from hcss.platform.db import Database
from hcss.platform.live import actions, trial_writer, validation
from hcss.platform.live.actions import ActionError
from hcss.platform.live.control import control_trial
from hcss.platform.live.leases import HostedElsewhere, trial_transaction
from hcss.platform.live.orders import PendingOrder, send_order
from hcss.platform.live.runner import Runner
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.models import CommandKey

__all__ = [
    "ActionError",
    "Answer",
    "Command",
    "Control",
    "Observe",
    "ProbeAnswer",
    "ProbeReady",
    "SubmitRequest",
    "carry_out",
    "carry_out_order",
]


@dataclass(frozen=True)
class Answer:
    """A command's outcome as the client gets it: HTTP status and JSON body."""

    status: int
    body: Any
    replayed: bool = False  # from the store: the command was carried out (or refused) before


@dataclass(frozen=True)
class SubmitRequest:
    """The participant's request (the POST body, unparsed: the door checks it)."""

    trial_id: int
    body: Any


@dataclass(frozen=True)
class Observe:
    """The participant's click on the map (the POST body, unparsed)."""

    trial_id: int
    body: Any


@dataclass(frozen=True)
class ProbeReady:
    """The participant's Ready press on the open probe."""

    trial_id: int
    probe_id: int


@dataclass(frozen=True)
class ProbeAnswer:
    """The participant's answer to the open probe (the POST body, unparsed)."""

    trial_id: int
    probe_id: int
    body: Any


@dataclass(frozen=True)
class Control:
    """The experimenter's pause, resume or abort; `order_id`: the `TrialOrder` it carries out
    (written by a console served by another process), marked done with the action's row."""

    trial_id: int
    action: str
    participant_id: int
    experimenter_id: int | None
    order_id: int | None = None


Command = SubmitRequest | Observe | ProbeReady | ProbeAnswer | Control

#: What a `Control` answers (body ``{"outcome": ...}``): carried out, or the trial had
#: reached its end first, or it was as asked already (nothing written); or the order is
#: sent to the host, which has not confirmed it within the wait (202).
SENT = "sent"
#: The console's command for a trial that runs nowhere (404): the console records the
#: action on the session alone.
NOT_RUNNING = "not_running"


def carry_out(
    database: Database, runner: Runner, command: Command, key: KeyedCommand | None = None
) -> Answer:
    """Find, lock, check, apply, write and answer `command`; with `key`, carried out once.

    Raises only what is not an answer of the command: `HostedElsewhere` for
    the participant's command on a trial another process hosts, and the
    database's errors (the app answers 503).
    """
    with runner.commanding(command.trial_id):  # not handed to another process meanwhile
        try:
            live = runner.host(command.trial_id, participant=not isinstance(command, Control))
        except HostedElsewhere:
            if not isinstance(command, Control) or command.order_id is not None:
                raise  # the page retries (503); an order waits for the trial's next host
            return _ordered(database, runner, command)
        with live.lock if live is not None else nullcontext():  # a key's repeats wait here
            if key is None:
                return _applied(database, runner, live, command, None)
            row = _stored(database, key)
            if row is not None:
                return _replayed(row, key)
            try:
                return _first(database, runner, live, command, key)
            except IntegrityError:
                # Only reachable if two processes served one trial (one server never
                # does: the lock above serialises its repeats); the stored answer wins,
                # and the action's transaction, command and key, was rolled back.
                row = _stored(database, key)
                if row is None:
                    raise
                return _replayed(row, key)


def _first(
    database: Database,
    runner: Runner,
    live: RunningTrial | None,
    command: Command,
    key: KeyedCommand,
) -> Answer:
    """The answer to a key's first command; `key` stored with it, by the action (a 2xx: in
    the transaction that recorded the command) or here (a refusal, which recorded nothing)."""
    answer = _applied(database, runner, live, command, key)
    if 400 <= answer.status < 500:
        with (
            database.session_scope() if live is None else trial_transaction(database, live)
        ) as session:
            trial_writer.write_command_key(session, key, answer.status, answer.body)
    return answer


def carry_out_order(database: Database, runner: Runner, order: PendingOrder) -> Answer:
    """A console's order for a trial hosted here (`Runner.carry_out_orders`), through the door."""
    return carry_out(
        database,
        runner,
        Control(
            order.trial_id,
            order.action,
            participant_id=order.participant_id,
            experimenter_id=order.experimenter_id,
            order_id=order.id,
        ),
    )


def refusal(error: ActionError) -> Answer:
    """An `ActionError` as the page gets it; a trial moving to another process says so."""
    held = {"held_by": "server"} if error.code == "moved" else {}
    return Answer(error.status, {"error": error.code, "message": error.message, **held})


def _applied(
    database: Database,
    runner: Runner,
    live: RunningTrial | None,
    command: Command,
    key: KeyedCommand | None,
) -> Answer:
    """Check and apply `command` to the trial (its lock held), written in one unit of work."""
    try:
        if isinstance(command, Control):
            if live is None:
                return Answer(404, {"error": NOT_RUNNING})
            outcome = control_trial(
                runner,
                live,
                command.action,
                participant_id=command.participant_id,
                experimenter_id=command.experimenter_id,
                order_id=command.order_id,
            )
            return Answer(200, {"outcome": outcome})
        if live is None:
            raise ActionError("the trial has ended", 409, "ended")
        if isinstance(command, SubmitRequest):
            with database.session_scope() as session:  # read-only: back in the pool first
                operator_command, selections = validation.parse_request(
                    command.body, live, session, command.trial_id
                )
            return Answer(
                200,
                actions.submit_request(database, live, operator_command, selections, key=key),
            )
        if isinstance(command, Observe):
            kind, collective, target, button = validation.parse_observation(command.body, live)
            return Answer(
                201,
                actions.record_observation(
                    database,
                    live,
                    kind=kind,
                    collective=collective,
                    target=target,
                    button=button,
                    key=key,
                ),
            )
        if isinstance(command, ProbeReady):
            return Answer(
                200,
                actions.probe_ready(database, live, command.probe_id, now=runner.clock(), key=key),
            )
        answer = validation.parse_answer(command.body)
        return Answer(
            200,
            actions.probe_answer(
                database, live, command.probe_id, answer, now=runner.clock(), key=key
            ),
        )
    except ActionError as error:
        return refusal(error)


def _ordered(database: Database, runner: Runner, command: Control) -> Answer:
    """The console's command for a trial another live process hosts: a `TrialOrder` for that
    host, which carries it out through this door; 202 if it has not confirmed it yet."""
    issued_by = "" if runner.leases is None else runner.leases.owner
    outcome = send_order(
        database,
        command.trial_id,
        command.action,
        experimenter_id=command.experimenter_id,
        issued_by=issued_by,
    )
    if outcome is None:
        return Answer(202, {"outcome": SENT})
    return Answer(200, {"outcome": outcome})


def _stored(database: Database, key: KeyedCommand) -> CommandKey | None:
    with database.session_scope() as session:
        row = session.scalars(
            select(CommandKey).where(CommandKey.trial_id == key.trial_id, CommandKey.key == key.key)
        ).first()
        if row is not None:
            session.expunge(row)
        return row


def _replayed(row: CommandKey, key: KeyedCommand) -> Answer:
    if (row.endpoint, row.fingerprint) != (key.endpoint, key.fingerprint):
        return refusal(
            ActionError(
                "this Idempotency-Key was already used for another command; send a fresh key",
                422,
                "idempotency_key_reused",
            )
        )
    return Answer(row.status, row.response, replayed=True)
