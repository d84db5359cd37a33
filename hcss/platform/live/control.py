"""The experimenter's pause, resume and abort of a live trial hosted by this process.

One place carries them out, whether the console that asked is served by this
process or by another one (whose `TrialOrder` the runner picked up): the
`ConsoleAction` row is written first, inside the trial's lock, then the
clock stops or runs on (or the trial ends), so the runner, the participant's
commands and the console never see a half-done pause.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from hcss.platform.live import trial_writer
from hcss.platform.live.leases import trial_transaction
from hcss.platform.live.orders import mark_done
from hcss.platform.live.recorder import kept_until_written, record_progress
from hcss.platform.models.participant_state import STATE_ACTIONS

if TYPE_CHECKING:
    from hcss.platform.live.runner import Runner
    from hcss.platform.live.running_trial import RunningTrial

#: What `control_trial` answers: carried out, or the trial had just reached its end.
DONE = "done"
ENDED = "ended"
#: The trial was already as asked (a second pause of a paused trial, racing the first):
#: nothing is written, so two concurrent pauses leave one console action.
ALREADY = "already"


def control_trial(
    runner: Runner,
    live: RunningTrial,
    action: str,
    *,
    participant_id: int,
    experimenter_id: int | None,
    order_id: int | None = None,
) -> str:
    """Pause, resume or abort the trial now; `ENDED` if it ended first (then only logged);
    `ALREADY` if it is paused (resumed) already, when nothing is written.

    `order_id`: the `TrialOrder` this carries out, marked done in the same
    transaction as the action's row, so a host that dies in between leaves
    either both or neither, and the next host never does it twice.

    The transaction is a recorder unit of work (`kept_until_written`): when
    its commit fails, an abort has ended nothing (the trial stays running in
    memory, its probe open), so the console's retry ends it once. It first
    writes what the trial holds unwritten (an advance that met a database
    outage), since the guard counts the queue written when it commits.
    """
    if action not in STATE_ACTIONS:
        raise ValueError(f"unknown session action {action!r}")
    now = runner.clock()
    # Advanced to `now` first: the clock stops (or the trial ends) at this instant.
    with runner.holding(live, now, advance=action != "resume"):
        # The state is checked here, under the lock, not by the caller before it: two
        # consoles pausing at once both saw a running trial, only the first pauses it.
        paused = live.paused_since is not None
        if not live.ended and (
            (action == "pause" and paused) or (action == "resume" and not paused)
        ):
            if order_id is not None:
                with trial_transaction(runner.database, live) as session:
                    mark_done(session, order_id, now, DONE)
            return ALREADY
        with kept_until_written(live), trial_transaction(runner.database, live) as session:
            if not live.ended:
                record_progress(live, session)
            if order_id is not None:
                mark_done(session, order_id, now, ENDED if live.ended else DONE)
            if live.ended:  # reached its time limit just now: the session's state still changes
                trial_writer.write_console_action(
                    session,
                    participant_id=participant_id,
                    experimenter_id=experimenter_id,
                    action=action,
                    at_epoch=now,
                )
                return ENDED
            trial_writer.write_console_action(
                session,
                participant_id=participant_id,
                experimenter_id=experimenter_id,
                action=action,
                trial_id=live.trial_id,
                at_epoch=now,
                detail=f"trial clock {live.clock(now):.1f} s",
            )
            if action == "abort":
                runner.end(live, session, "aborted", now)
        if action == "pause":
            runner.pause(live, now)
        elif action == "resume":
            runner.resume(live, now)
    return DONE
