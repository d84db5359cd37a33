"""The live service's one door: every command for a running trial, a value in, an answer out.

The participant's request, map click, probe Ready and probe answer, and the
experimenter's pause, resume and abort, are each a small frozen value
(hcss.platform.live.commands: `SubmitRequest`, `Observe`, `ProbeReady`,
`ProbeAnswer`, each with its declaration in the table `COMMANDS`; here:
`Control`), and `carry_out` is the one function that takes them. For every
command it

1. finds the trial: hosted here, claimed and rebuilt now (only by its
   placement home, or after its holder's lease ran out), or hosted by
   another process, which keeps it (the participant's command:
   `HostedElsewhere`, which the API forwards to the holder through nginx,
   hcss.platform.live.forwarding, writing nothing here; the console's: a
   `TrialOrder` that the host carries out through this same door);
2. takes the trial's lock, and with an idempotency key looks the key up
   first: a repeat, even one racing the first, waits for the lock and is
   answered from the stored row without touching the trial again, and a key
   sent with another command is refused (422);
3. checks the trial's state under that lock: here for every participant's
   command alike (moved, ended, paused), then by the command's declaration
   (the probe still open and its question shown or not, the click on the
   map); the console's: the trial advanced to now, then ended, or paused or
   running already, when nothing is written;
4. applies the command and writes it in one trial unit of work
   (hcss.platform.live.unit_of_work; the participant's by its declaration,
   the console's by hcss.platform.live.control), which says what happened
   as a typed fact (`live.facts`) written with the key, and settles a commit
   that fails by asking the database whether the command's row is there: the
   trial in memory then moves on as the log says, stays as it was, or, when
   nobody can say, is marked moved and rebuilt from the log;
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
from typing import TYPE_CHECKING, Any

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

from hcss.platform.db import Database
from hcss.platform.live import control, trial_writer
from hcss.platform.live.commands import COMMANDS, ActionError, Declaration, ParticipantCommand
from hcss.platform.live.leases import HostedElsewhere, LeaseLost
from hcss.platform.live.orders import PendingOrder, send_order
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.live.unit_of_work import trial_transaction, trial_unit
from hcss.platform.models import CommandKey
from hcss.platform.models.participant_state import STATE_ACTIONS

if TYPE_CHECKING:
    from hcss.platform.live.runner import Runner
    from hcss.platform.live.running_trial import RunningTrial

__all__ = ["ActionError", "Answer", "Command", "Control", "carry_out", "carry_out_order"]


@dataclass(frozen=True)
class Answer:
    """A command's outcome as the client gets it: HTTP status and JSON body."""

    status: int
    body: Any
    replayed: bool = False  # from the store: the command was carried out (or refused) before


@dataclass(frozen=True)
class Control:
    """The experimenter's pause, resume or abort; `order_id`: the `TrialOrder` it carries out
    (written by a console served by another process), marked done with the action's row."""

    trial_id: int
    action: str
    participant_id: int
    experimenter_id: int | None
    order_id: int | None = None


Command = ParticipantCommand | Control

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
    """Find, lock, check, apply, write and answer `command`, carried out once per `key`.

    A participant's command comes with its key (the API refuses one without);
    a console's `Control` has none: it is carried out once by its state check
    (a second pause finds the trial paused and writes nothing). Raises only
    what is not an answer of the command: `HostedElsewhere` for the
    participant's command on a trial another process hosts, and the
    database's errors (the app answers 503).
    """
    if isinstance(command, Control) != (key is None):
        raise ValueError("a participant's command carries its key, a console's control none")
    with runner.commanding(command.trial_id):  # not handed to another process meanwhile
        try:
            live = runner.host(command.trial_id, participant=not isinstance(command, Control))
        except HostedElsewhere:
            if not isinstance(command, Control) or command.order_id is not None:
                raise  # the page retries (503); an order waits for the trial's next host
            return _ordered(database, runner, command)
        with live.lock if live is not None else nullcontext():  # a key's repeats wait here
            if key is None:  # the console's control
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
    """Check `command` against the trial's state (its lock held), then apply and write it."""
    try:
        if isinstance(command, Control):
            if live is None:
                return Answer(404, {"error": NOT_RUNNING})
            return Answer(200, {"outcome": _controlled(runner, live, command)})
        assert key is not None  # `carry_out` checked it
        if live is None:
            raise ActionError("the trial has ended", 409, "ended")
        declared = COMMANDS[type(command)]
        # The body is read first (a malformed one is refused whatever the trial's state),
        # then the state is checked, then the command is applied and written.
        parsed = declared.parse(command, live, database)
        _check_running(live)
        declared.check(live, parsed)
        return _carried(database, live, declared, parsed, key, runner.clock())
    except ActionError as error:
        return refusal(error)


def _carried(
    database: Database,
    live: RunningTrial,
    declared: Declaration[Any, Any],
    parsed: Any,
    key: KeyedCommand,
    now: float,
) -> Answer:
    """A participant's command applied and written in one trial unit of work, by its
    declaration; the trial in memory moves on once it is committed (or its commit's lost
    answer is found stored)."""
    before = live.sim.snapshot() if declared.changes_simulation else None
    fact = declared.fact(live, parsed, now)
    try:
        with trial_unit(database, live, simulation_restored=before is not None) as unit:
            row_id = unit.command(
                fact, key, lambda row: declared.answer(fact, row), declared.status
            )
            declared.also_written(unit)
    except BaseException:
        if before is not None:
            live.roll_back_to(before)  # it was not logged: it never happened
        raise
    declared.taken(live, parsed, fact, row_id, now)
    live.touch()
    return Answer(declared.status, declared.answer(fact, row_id))


# --- the state checks: under the trial's lock, before anything is applied ----------------


def _check_running(live: RunningTrial) -> None:
    """The participant's command applies only to a trial that runs here, unpaused."""
    if live.moved:  # its lease was lost under this command: the new host must carry it out
        raise ActionError("the trial moved to another server process; try again", 503, "moved")
    if live.ended:
        raise ActionError("the trial has ended", 409, "ended")
    if live.trial_clock.paused_since is not None:
        raise ActionError("the experimenter has paused the trial", 409, "paused")


def _controlled(runner: Runner, live: RunningTrial, command: Control) -> str:
    """The console's pause, resume or abort: the trial advanced to now (its clock stops, or it
    ends, at this instant), its state checked, then carried out (hcss.platform.live.control).

    The state is checked here, under the lock, not by the console before it:
    two consoles pausing at once both saw a running trial; only the first
    pauses it, the second finds it paused and writes nothing.
    """
    if command.action not in STATE_ACTIONS:
        raise ValueError(f"unknown session action {command.action!r}")
    now = runner.clock()
    with runner.holding(live, now, advance=command.action != "resume"):
        if live.moved:  # another process hosts it now: the order waits for that host
            raise LeaseLost(live.trial_id)
        paused = live.trial_clock.paused_since is not None
        if not live.ended and (
            (command.action == "pause" and paused) or (command.action == "resume" and not paused)
        ):
            return control.as_it_was(runner, live, now, command.order_id)
        return control.control_trial(
            runner,
            live,
            command.action,
            now,
            participant_id=command.participant_id,
            experimenter_id=command.experimenter_id,
            order_id=command.order_id,
        )


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
