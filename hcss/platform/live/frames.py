"""What a stream is made of: frames of the trial's state (Server-Sent Events), at least
twice a second and at once on change; and the live service's reads for the participant's
API: the stream (`open_stream`) and one frame for scripts that poll (`frame`). The participant's commands go through `door`.

Each event's id is the newest System Message number it carries; EventSource
sends it back as Last-Event-ID on reconnect, so no message is shown twice or
lost across a dropped connection or a server restart.
"""

from __future__ import annotations

import json
import time as wallclock
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from sqlalchemy import select

from hcss.platform.db import Database
from hcss.platform.live import trials
from hcss.platform.live.commands import ActionError
from hcss.platform.live.stream_slots import StreamSlots, takeover_frame
from hcss.platform.models import Participant, StudyEnrolment, Trial
from hcss.platform.models.vocabularies import TrialStatus

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial

MIN_GAP_S = 0.05  # at most 20 frames a second per stream, even under acceleration


def trial_frame(live: RunningTrial, now: float, after_seq: int) -> tuple[str, int]:
    """One stream frame (JSON text) of the trial at `now`, with the System Messages after
    `after_seq`, and the newest message seq it carries; call with the trial's lock held.

    The probe on screen counts as delivered with the first frame that carries it.
    """
    probe = live.probes.current
    if probe is not None:
        probe.delivered(live.trial_clock.running_wall_s(now))
    new_messages = [m for m in live.messages if m["seq"] > after_seq]
    last_seq = new_messages[-1]["seq"] if new_messages else after_seq
    head = {
        "trial": {
            "id": live.trial_id,
            "kind": live.kind,
            # The page's status: the trial's, or "paused" while the experimenter holds it.
            "status": TrialStatus.ENDED
            if live.ended
            else ("paused" if live.trial_clock.paused_since is not None else TrialStatus.RUNNING),
            "clock_s": round(live.trial_time(now), 2),
            "duration_s": live.duration_s,
            "step": live.sim.step_count,
            "version": live.version,
            # Why a pause the experimenter did not make: the database is away.
            "held_by": None if live.trial_clock.database_away_since is None else "database",
            # Why it ended ("time_limit", "aborted"): the page words it.
            "end_reason": live.end_reason if live.ended else None,
        },
        "messages": new_messages,
        "probe": None if probe is None else probe.public(),
    }
    text = json.dumps(head, separators=(",", ":"))
    return text[:-1] + ',"view":' + live.view_json() + "}", last_seq


def event_stream(
    live: RunningTrial,
    *,
    after_seq: int,
    interval_s: float,
    max_s: float,
    clock: Callable[[], float],
    superseded: Callable[[], bool] = lambda: False,
) -> Iterator[str]:
    """Frames until the trial ends or `max_s` passes (then the browser reconnects).

    When a newer stream of the same link takes over (`superseded`), this one
    sends a ``takeover`` event and closes (see hcss.platform.live.stream_slots).
    """
    yield "retry: 1000\n\n"
    stop_at = wallclock.monotonic() + max_s
    sent_version = -1
    last_sent = 0.0
    due = wallclock.monotonic()  # when the next frame is due even if nothing changed
    while True:
        with live.changed:
            if live.version == sent_version and not live.ended:
                live.changed.wait(timeout=max(0.0, due - wallclock.monotonic()))
            if superseded():
                break
            if live.moved:
                return  # closed without an ending: the browser reconnects, to the host
            text, after_seq = trial_frame(live, clock(), after_seq)
            sent_version, ended = live.version, live.ended
        # Due one interval after the last frame was: a send that takes time (200
        # streams under load) must not stretch the period beyond the interval.
        made = wallclock.monotonic()
        due = due + interval_s if made - interval_s < due <= made else made + interval_s
        yield f"id: {after_seq}\ndata: {text}\n\n"
        if ended or wallclock.monotonic() >= stop_at:
            return
        gap = MIN_GAP_S - (wallclock.monotonic() - last_sent)
        last_sent = wallclock.monotonic()
        if gap > 0:
            wallclock.sleep(gap)
    yield takeover_frame()


def ended_stream(trial_id: int, duration_s: float, end_reason: str | None = None) -> Iterator[str]:
    """For a trial no longer live: one frame saying so (and why, when known), then close."""
    frame = {
        "trial": {
            "id": trial_id,
            "status": TrialStatus.ENDED,
            "clock_s": duration_s,
            "end_reason": end_reason,
        }
    }
    yield f"retry: 5000\ndata: {json.dumps(frame)}\n\n"


class Hosting(Protocol):
    """What a stream needs of the runner: the trial hosted here, and the clock it steps by
    (`runner.Runner` is one; frames do not import it, so the runner stays below the stream)."""

    def host(self, trial_id: int, *, participant: bool = False) -> RunningTrial | None: ...

    @property
    def clock(self) -> Callable[[], float]: ...


def _running(runner: Hosting, trial_id: int) -> RunningTrial:
    """The trial hosted here for the participant's request: claimed here if nobody holds it
    and this process is its placement home; `HostedElsewhere` (the request is forwarded to
    the holder, hcss.platform.live.forwarding) if another live process holds it or is its
    home. The trial never moves for a request."""
    live = runner.host(trial_id, participant=True)
    if live is None:
        raise ActionError("the trial has ended", 409, "ended")
    return live


def frame(runner: Hosting, trial_id: int) -> str:
    """One frame of the stream as JSON text, for bots and scripts that poll."""
    live = _running(runner, trial_id)
    with live.lock:
        text, _ = trial_frame(live, runner.clock(), 0)
    return text


@dataclass(frozen=True)
class Stream:
    """A trial's Server-Sent Events: its frames, and what to do once the connection closes."""

    frames: Iterator[str]
    closed: Callable[[], None] = lambda: None


def open_stream(
    database: Database,
    runner: Hosting,
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
            reason = trials.end_reason(session, trial.id)
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
