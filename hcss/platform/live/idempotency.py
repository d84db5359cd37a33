"""Idempotent commands: a repeated POST with the same key gets the first answer back.

The Collective Interface sends an ``Idempotency-Key`` header (a fresh UUID)
with every command. The first POST with a key is carried out under the
trial's lock and its answer, status and JSON body, is stored with the key
(`CommandKey`, unique per trial and key); a repeat, whether it arrives after
the first or races it, waits for that lock and is answered from the stored
row without touching the trial again. A key sent with a different command
(another route, probe or body) is refused with 422.

The key of a command that records something is written by the action itself
(the decorator hands the view its `key`, a `CommandKey` not yet stored, and the
view passes it to `hcss.platform.live.actions`), in the transaction
that records the command: both are committed or neither is. Were the key
written afterwards, a server killed (or a write failing) between the two
commits would leave the command without its key, and the client's retry
with the same key would record it a second time.

An answer that recorded nothing (a refusal at validation: bad JSON, a closed
probe, a paused trial) is stored with its key in a transaction of its own,
so a repeat gets the same refusal even after the trial has moved on; if that
write is lost, the retry is merely validated afresh, which records nothing
twice. A 5xx answer, or one that is not JSON, is not stored: the client may
try again with the same key.

A POST without the header is carried out as before, without protection
against repeats: scripts and bots that predate keys keep working. A header
that is present but malformed gets a 400 and changes nothing.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable
from contextlib import nullcontext
from functools import wraps
from typing import Any

from flask import Response, current_app, jsonify, request
from sqlalchemy import inspect, select
from sqlalchemy.exc import IntegrityError

from hcss.platform.db import database
from hcss.platform.live.access import require_owner, runner
from hcss.platform.live.actions import ActionError
from hcss.platform.models import CommandKey

KEY_HEADER = "Idempotency-Key"
KEY_PATTERN = re.compile(r"[A-Za-z0-9_-]{8,64}")


def command_key() -> str | None:
    """The request's key; None when absent; ActionError (400) when malformed."""
    raw = request.headers.get(KEY_HEADER)
    if raw is None:
        return None
    if not KEY_PATTERN.fullmatch(raw):
        raise ActionError(
            f"'{KEY_HEADER}' must be 8 to 64 letters, digits, '-' or '_' "
            "(a fresh one per command, e.g. a UUID)",
            400,
            "bad_idempotency_key",
        )
    return raw


def _fingerprint() -> str:
    """The command a key stands for: route, its arguments and the raw body (never parsed)."""
    digest = hashlib.sha256()
    digest.update(str(request.endpoint).encode())
    digest.update(repr(sorted((request.view_args or {}).items())).encode())
    digest.update(b"\0")
    digest.update(request.get_data(cache=True))
    return digest.hexdigest()


def _stored(trial_id: int, key: str) -> CommandKey | None:
    with database().session_scope() as session:
        row = session.scalars(
            select(CommandKey).where(CommandKey.trial_id == trial_id, CommandKey.key == key)
        ).first()
        if row is not None:
            session.expunge(row)
        return row


def _replay(row: CommandKey, fingerprint: str) -> Response:
    if row.endpoint != str(request.endpoint) or row.fingerprint != fingerprint:
        raise ActionError(
            f"this {KEY_HEADER} was already used for another command; send a fresh key",
            422,
            "idempotency_key_reused",
        )
    response = jsonify(row.response)
    response.status_code = row.status
    response.headers["Idempotent-Replayed"] = "true"
    return response


def idempotent(view: Callable[..., Any]) -> Callable[..., Any]:
    """Route decorator: carry out a keyed command once and answer repeats from the store.

    The view is called with `key`: the request's `CommandKey`, not yet stored,
    for the action to store with what it records; None when the POST has no key.
    """

    @wraps(view)
    def wrapper(token: str, trial_id: int, **kwargs: Any) -> Any:
        key = command_key()
        if key is None:
            return view(token, trial_id, key=None, **kwargs)
        require_owner(token, trial_id)  # 404 for another participant's trial
        fingerprint = _fingerprint()
        live = runner().get(trial_id)
        with live.lock if live is not None else nullcontext():  # repeats wait here
            row = _stored(trial_id, key)
            if row is not None:
                return _replay(row, fingerprint)
            pending = CommandKey(
                trial_id=trial_id, key=key, endpoint=str(request.endpoint), fingerprint=fingerprint
            )
            try:
                response = _carry_out(view, token, trial_id, kwargs, pending)
            except IntegrityError:
                # Only reachable if two processes served one trial (one server never
                # does: the lock above serialises its repeats); the stored answer wins,
                # and the action's transaction, command and key, was rolled back.
                row = _stored(trial_id, key)
                if row is None:
                    raise
                return _replay(row, fingerprint)
            return response

    return wrapper


def _carry_out(
    view: Callable[..., Any], token: str, trial_id: int, kwargs: dict[str, Any], key: CommandKey
) -> Response:
    """The view's answer; `key` stored with it, by the action or (nothing recorded) here."""
    try:
        response = current_app.make_response(view(token, trial_id, key=key, **kwargs))
    except ActionError as error:
        response = jsonify(error=error.code, message=error.message)
        response.status_code = error.status
    if inspect(key).has_identity:  # the action committed it with the command
        if (key.status, key.response) != (response.status_code, response.get_json()):
            raise RuntimeError(f"{request.endpoint} answered otherwise than it stored")
        return response
    if response.status_code >= 500 or not response.is_json:
        return response  # not an outcome: the client may try again with the key
    if response.status_code < 400:
        raise RuntimeError(f"{request.endpoint} recorded a command without its key")
    key.status, key.response = response.status_code, response.get_json()
    with database().session_scope() as session:
        session.add(key)  # a refusal: nothing else was written
    return response
