"""The experimenter's pause, resume and abort of a live trial hosted by this process: applied
and written.

One place carries them out, whether the console that asked is served by this
process or by another one (whose `TrialOrder` the runner picked up): the live
service's door (hcss.platform.live.door) finds the trial, takes its lock,
advances it to now and checks its state (ended, or already as asked); these
functions are its apply-and-write step. The `ConsoleAction` row
(`facts.ConsoleActed`) is written first, inside the trial's lock, then the
clock stops or runs on (or the trial ends), so the runner, the participant's
commands and the console never see a half-done pause.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from hcss.platform.live.facts import ConsoleActed
from hcss.platform.live.orders import mark_done
from hcss.platform.live.recorder import record_progress
from hcss.platform.live.unit_of_work import trial_unit

if TYPE_CHECKING:
    from hcss.platform.live.runner import Runner
    from hcss.platform.live.running_trial import RunningTrial

#: What a console's command answers: carried out, or the trial had just reached its end.
DONE = "done"
ENDED = "ended"
#: The trial was already as asked (a second pause of a paused trial, racing the first):
#: nothing is written, so two concurrent pauses leave one console action.
ALREADY = "already"


def as_it_was(runner: Runner, live: RunningTrial, now: float, order_id: int | None) -> str:
    """The trial is as asked already: nothing is written but the order's confirmation."""
    if order_id is not None:
        with trial_unit(runner.database, live) as unit:
            mark_done(unit.session, order_id, now, DONE)
    return ALREADY


def control_trial(
    runner: Runner,
    live: RunningTrial,
    action: str,
    now: float,
    *,
    participant_id: int,
    experimenter_id: int | None,
    order_id: int | None = None,
) -> str:
    """Pause, resume or abort the trial at `now` (the door has checked that it may: its lock
    held, advanced to `now`); `ENDED` if it reached its end first (then only logged).

    `order_id`: the `TrialOrder` this carries out, marked done in the same
    transaction as the action's row, so a host that dies in between leaves
    either both or neither, and the next host never does it twice.

    The transaction is a trial unit of work (hcss.platform.live.unit_of_work):
    when its commit fails, an abort has ended nothing (the trial stays running
    in memory, its probe open), so the console's retry ends it once. It first
    writes what the trial holds unwritten (an advance that met a database
    outage), since the unit counts the queue written when it commits. A
    commit that failed but landed (its answer lost) is found by the unit
    asking the database: the trial in memory is then marked moved, so the
    runner drops it and the next request rebuilds it from the log, which
    holds the action.
    """
    acted = ConsoleActed(
        participant_id=participant_id,
        experimenter_id=experimenter_id,
        action=action,
        at_epoch=now,
        on_trial=not live.ended,
        detail=None if live.ended else f"trial clock {live.trial_time(now):.1f} s",
    )
    with trial_unit(runner.database, live) as unit:
        if not live.ended:
            record_progress(live, unit.session)
        if order_id is not None:
            mark_done(unit.session, order_id, now, ENDED if live.ended else DONE)
        unit.command(acted)
        if action == "abort" and acted.on_trial:
            runner.end(live, unit.session, "aborted", now)
    if unit.answer_lost:
        live.move_away()  # the log holds the action, the trial in memory does not: rebuilt
        return DONE if acted.on_trial else ENDED
    if not acted.on_trial:  # reached its time limit just now: the session's state still
        return ENDED  # changes
    if action == "pause":
        runner.pause(live, now)
    elif action == "resume":
        runner.resume(live, now)
    return DONE
