"""What a stream is made of: frames of the trial's state (Server-Sent Events), at least
twice a second and at once on change.

Each event's id is the newest System Message number it carries; EventSource
sends it back as Last-Event-ID on reconnect, so no message is shown twice or
lost across a dropped connection or a server restart.
"""

from __future__ import annotations

import json
import time as wallclock
from collections.abc import Callable, Iterator

from hcss.platform.live.running_trial import RunningTrial
from hcss.platform.live.stream_slots import takeover_frame
from hcss.platform.models.vocabularies import TrialStatus

MIN_GAP_S = 0.05  # at most 20 frames a second per stream, even under acceleration


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
            text, after_seq = live.frame(clock(), after_seq)
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
