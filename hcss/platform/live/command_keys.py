"""The live service's rule for keyed commands: carried out once, a repeat answered from the store.

The first command with a key (`CommandKey`, unique per trial and key) is
carried out under the trial's lock, and its answer, status and JSON body, is
stored with the key; a repeat, whether it arrives after the first or races it,
waits for that lock and is answered from the stored row without touching the
trial again. A key sent with a different command (another route, probe or
body: the key's endpoint and fingerprint) is refused with 422.

The key of a command that records something is written by the action itself
(hcss.platform.live.actions), in the transaction that records the command:
both are committed or neither is. Were the key written afterwards, a server
killed (or a write failing) between the two commits would leave the command
without its key, and the client's retry with the same key would record it a
second time.

An answer that recorded nothing (a refusal at validation: bad JSON, a closed
probe, a paused trial) is stored with its key in a transaction of its own, so
a repeat gets the same refusal even after the trial has moved on; if that
write is lost, the retry is merely validated afresh, which records nothing
twice. A 5xx answer is not stored: the client may try again with the same key.

The HTTP side (the header, the fingerprint, the route decorator) is
hcss.platform.live.idempotency; the lock and the key's rows stay here, inside live.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any

from sqlalchemy import select
from sqlalchemy.exc import IntegrityError

from hcss.platform.db import Database
from hcss.platform.live import trial_writer
from hcss.platform.live.actions import ActionError
from hcss.platform.live.leases import trial_transaction
from hcss.platform.live.runner import Runner
from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.trial_writer import KeyedCommand
from hcss.platform.models import CommandKey


@dataclass(frozen=True)
class Answer:
    """A command's outcome as the client gets it: HTTP status and JSON body."""

    status: int
    body: Any
    replayed: bool = False  # from the store: the command was carried out (or refused) before


def once(
    database: Database,
    runner: Runner,
    key: KeyedCommand,
    carry_out: Callable[[KeyedCommand], Answer],
) -> Answer:
    """`carry_out(key)` if the key is new, else the stored answer; `key` is not yet stored.

    `carry_out` hands the key to the action, which stores it with what it records.
    """
    live = runner.host(key.trial_id, participant=True)
    with live.lock if live is not None else nullcontext():  # repeats wait here
        row = _stored(database, key)
        if row is not None:
            return _replayed(row, key)
        try:
            return _first(database, key, carry_out, live)
        except IntegrityError:
            # Only reachable if two processes served one trial (one server never
            # does: the lock above serialises its repeats); the stored answer wins,
            # and the action's transaction, command and key, was rolled back.
            row = _stored(database, key)
            if row is None:
                raise
            return _replayed(row, key)


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
        raise ActionError(
            "this Idempotency-Key was already used for another command; send a fresh key",
            422,
            "idempotency_key_reused",
        )
    return Answer(row.status, row.response, replayed=True)


def _first(
    database: Database,
    key: KeyedCommand,
    carry_out: Callable[[KeyedCommand], Answer],
    live: RunningTrial | None,
) -> Answer:
    """The command's answer; `key` stored with it, by the action (a 2xx: in the transaction
    that recorded the command) or here (a refusal, which recorded nothing)."""
    answer = carry_out(key)
    if answer.status < 400:
        return answer  # the action committed the key with the command
    if answer.status >= 500:
        return answer  # not an outcome: the client may try again with the key
    with database.session_scope() if live is None else trial_transaction(database, live) as session:
        trial_writer.write_command_key(session, key, answer.status, answer.body)
    return answer
