"""Idempotent commands over HTTP: a repeated POST with the same key gets the first answer back.

The Collective Interface sends an ``Idempotency-Key`` header (a fresh UUID)
with every command. The route decorator here reads the key and a fingerprint
of the command (route, arguments, raw body) and hands them to the view as a
value, which passes it to the live service's door (hcss.platform.live.door);
the door carries the first POST with a key out once under the trial's lock and stores its answer with the key, in the
action's own transaction when it records something; a repeat gets that answer
back (header ``Idempotent-Replayed``), and a key reused for another command is
refused with 422. The view itself never runs under the trial's lock.

A POST without the header is refused with a 400 (``idempotency_key_required``)
and changes nothing: the page and both bots send a key with every command,
so a command is carried out once however often its answer is lost. A header
that is present but malformed gets a 400 too.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable
from functools import wraps
from typing import Any

from flask import request

from hcss.platform.live.access import require_owner
from hcss.platform.live.commands import ActionError
from hcss.platform.live.trial_writer import KeyedCommand

KEY_HEADER = "Idempotency-Key"
KEY_PATTERN = re.compile(r"[A-Za-z0-9_-]{8,64}")


def command_key() -> str:
    """The request's key; ActionError (400) when absent or malformed."""
    raw = request.headers.get(KEY_HEADER)
    if raw is None:
        raise ActionError(
            f"send an '{KEY_HEADER}' header with every command (a fresh one per command, "
            "e.g. a UUID), so that a command sent again is carried out once",
            400,
            "idempotency_key_required",
        )
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


def idempotent(view: Callable[..., Any]) -> Callable[..., Any]:
    """Route decorator: the request's key, read and checked, handed to the view as a value.

    The view is called with `key`: the request's key as a value (`KeyedCommand`),
    for the action to store with what it records. The token's ownership of the
    trial is checked first (404), so another participant's trial answers the
    same whatever the headers, and never has a key stored.
    """

    @wraps(view)
    def wrapper(token: str, trial_id: int, **kwargs: Any) -> Any:
        require_owner(token, trial_id)
        key = KeyedCommand(
            trial_id=trial_id,
            key=command_key(),
            endpoint=str(request.endpoint),
            fingerprint=_fingerprint(),
        )
        return view(token, trial_id, key=key, **kwargs)

    return wrapper
