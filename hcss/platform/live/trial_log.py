"""The trial log: what a trial's rows say, and the one way to rebuild its Simulation from them.

The live rebuild after a restart, the console's replay and the tests' oracle
all build a trial's Simulation the same way: the trial row's scenario, model
and parameters, then its command log applied at the logged steps through the
simulation's own deterministic `replay`. `build_simulation` is that way. The
System Messages a page showed are read back from the log by `shown_messages`
(the live page's after a restart, the replay's timeline), each command's
worded by `command_message`, which the live command uses too.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from sqlalchemy import Row, select
from sqlalchemy.orm import Session

from hcss.platform.models import (
    Command,
    CommandOutcome,
    Observation,
    SimEvent,
    Snapshot,
    Trial,
)
from hcss.platform.models.stored_names import Uninterpretable, stored_collective_name
from hcss.simulation.messages import accepted_text, refusal_text, request_subject

if TYPE_CHECKING:
    from datetime import datetime

    from hcss.simulation import Simulation
    from hcss.simulation.requests import RequestOutcome


def observation_actions(
    session: Session, trial_id: int
) -> list[Row[int, float, datetime, str, int | None, int | None, str]]:
    """The study's observation actions: every click no committed request names.

    A left-click that filled the request form is logged when it happens; if
    the request is then committed, its `Command.selections` names the click,
    and it counts as part of the request instead.

    Read as columns (id, sim_time, created_at, kind, collective, target, button), not
    ORM objects: a trial holds thousands of clicks, and the export reads every trial's.
    """
    used: set[int] = set()
    for selections in session.scalars(
        select(Command.selections).where(Command.trial_id == trial_id)
    ):
        used.update(int(i) for i in selections or [])
    clicks = session.execute(
        select(
            Observation.id,
            Observation.sim_time,
            Observation.created_at,
            Observation.kind,
            Observation.collective,
            Observation.target,
            Observation.button,
        )
        .where(Observation.trial_id == trial_id)
        .order_by(Observation.id)
    )
    return [click for click in clicks if click.id not in used]


def newest_snapshot(session: Session, trial_id: int) -> Snapshot | None:
    """The trial's latest snapshot (a rebuild and a replay both start from it)."""
    return session.scalars(
        select(Snapshot)
        .where(Snapshot.trial_id == trial_id)
        .order_by(Snapshot.step.desc(), Snapshot.id.desc())
        .limit(1)
    ).first()


def command_log(session: Session, trial_id: int, through_id: int | None = None) -> list[Command]:
    """The trial's commands in the order they were applied (those up to `through_id`, if given)."""
    query = select(Command).where(Command.trial_id == trial_id).order_by(Command.id)
    if through_id is not None:
        query = query.where(Command.id <= through_id)
    return list(session.scalars(query))


def new_simulation(trial: Trial) -> Simulation:
    """The trial's Simulation at step 0, from its row: scenario, model and stored parameters."""
    from hcss.simulation import Params, Scenario, Simulation

    params = Params.from_dict(trial.params) if trial.params else None
    return Simulation(Scenario.from_dict(trial.scenario), model=trial.model, params=params)


def build_simulation(
    session: Session,
    trial: Trial,
    until_step: int | None = None,
    *,
    start: Simulation | None = None,
    through_command: int | None = None,
    after_command: int | None = None,
    on_outcome: Callable[[Command, RequestOutcome], None] | None = None,
    on_step: Callable[[Simulation], None] | None = None,
) -> Simulation:
    """The trial's Simulation at `until_step`, its logged commands applied where they were live.

    `start` goes on from a Simulation already built or restored from a
    snapshot (it is stepped in place and returned); without it the build
    starts from the trial row at step 0. `until_step` None: up to the step of
    the last command logged. `through_command` leaves out later commands (a
    live trial's replay stops at its newest snapshot). `after_command`: `start`
    holds every logged command up to this id (a snapshot's `last_command_id`,
    0 for none) and only later ones are applied; without it, `start`'s count
    of applied commands says how many of the log it holds. `on_outcome` hears each
    command applied here, with its row; `on_step` sees every step reached.
    A log that contradicts `start` (fewer commands than it holds, or one
    logged before its step) raises RuntimeError: the trial cannot be rebuilt.
    """
    from hcss.simulation.replay import replay

    commands = command_log(session, trial.id, through_command)
    sim = start if start is not None else new_simulation(trial)
    if after_command is not None:
        held = sum(1 for c in commands if c.id <= after_command)
    else:
        held = sim.commands_applied
    if held > len(commands):
        raise RuntimeError(
            f"trial {trial.id}: the simulation holds {held} commands, the log only {len(commands)}"
        )
    if until_step is None:
        pending = commands[held:]
        until_step = max([c.step_applied for c in pending], default=sim.step_count)

    def heard(i: int, outcome: RequestOutcome) -> None:
        if on_outcome is not None:
            on_outcome(commands[i], outcome)

    try:
        return replay(
            sim.scenario,
            sim.model,
            [(c.step_applied, c.operator_command()) for c in commands],
            until_step,
            start=sim,
            held=held,
            on_outcome=heard,
            on_step=on_step,
        )
    except ValueError as error:  # a command logged before the start's step
        raise RuntimeError(f"trial {trial.id}: {error}") from error


#: Where a message falls among those of the same step (`_restore_messages`).
_STEP_EVENTS, _COMMANDS = 0, 1


def shown_messages(
    session: Session,
    trial_id: int,
    n_collectives: int | None = None,
    unworded: Callable[[Command, Uninterpretable], None] | None = None,
) -> list[tuple[float, str, str]]:
    """(time, kind, text) of every System Message the participant's page showed, in order:
    the simulation's events, and each command accepted or refused (the replay shows the same).

    Live, the runner records a step's events as soon as it reaches the step,
    under the trial's lock; a command lands between two steps, so at the time
    of a step its events come first, then the commands applied there, each
    kind in the order of its rows. Ids of two tables are never compared.
    """
    n = n_collectives
    events = [
        (e.sim_time, _STEP_EVENTS, e.id, e.kind, e.text)
        for e in session.scalars(select(SimEvent).where(SimEvent.trial_id == trial_id))
    ]
    outcomes = session.execute(
        select(Command, CommandOutcome)
        .join(CommandOutcome, CommandOutcome.command_id == Command.id)
        .where(Command.trial_id == trial_id)
    )
    for command, outcome in outcomes:
        try:
            kind, text = command_message(
                command, outcome.accepted, outcome.request_id, outcome.reason, n
            )
            events.append((command.sim_time, _COMMANDS, command.id, kind, text))
        except Uninterpretable as error:
            if unworded is not None:
                unworded(command, error)
    return [(time, kind, text) for time, _rank, _id, kind, text in sorted(events)]


class LoggedRequest(Protocol):
    """A request as its row names it: a `Command` row, or the `facts.CommandApplied` it is made of."""

    @property
    def kind(self) -> str: ...
    @property
    def collective(self) -> int | None: ...
    @property
    def target(self) -> int | None: ...
    @property
    def cancel_request_id(self) -> int | None: ...


def command_message(
    command: LoggedRequest,
    accepted: bool,
    request_id: int | None,
    reason: str,
    n_collectives: int | None = None,
) -> tuple[str, str]:
    """(``accepted`` or ``refusal``, the System Message) of a logged command.

    Uninterpretable for a collective the trial does not have (a row written by hand).
    """
    name = None
    if command.kind != "cancel":
        name = stored_collective_name(command.collective, n_collectives)
    subject = request_subject(command.kind, name, command.target, command.cancel_request_id)
    if accepted:
        return "accepted", accepted_text(subject, command.kind, request_id)
    return "refusal", refusal_text(subject, reason)
