"""A `RunningTrial`: one trial in memory, its simulation, lock, clock and what the page sees.

Everything that touches the simulation holds `lock`: the runner's steps, the
commands between them, and the stream reading a frame. `changed` wakes the
streams whenever the state moved, so a command's effect is sent at once.

Its state changes only through its methods, named for what happened (a
pause, a command applied, a probe shown, rows written), so the rules that
keep it consistent (the recorder's cursors move only with a commit, the clock
stands still while the database is away) have one place each. Those that move
its log on return what happened as typed facts (`live.facts`: events handed
over, decisions made, request statuses changed, a probe timed out or scored,
a snapshot taken, the trial ended), which the trial log's writer stores; none
does I/O. The clock, the
probes and the trial log's progress are small classes of their own
(`clock.TrialClock`, `progress.ProbeSchedule`, `progress.LogQueue`), whose
methods say why. Others read them as read-only parts (`trial_clock`, `probes`,
`log`: protocols without their changing methods) and change them only
through the trial's verbs (before issue 41, 32 one-line pass-throughs did
both).
"""

from __future__ import annotations

import json
import math
import threading
from typing import TYPE_CHECKING, Any, Protocol

from hcss.platform.live.clock import TrialClock
from hcss.platform.live.facts import (
    DecisionMade,
    EventHappened,
    ProbeTimedOut,
    ProjectionScored,
    TrialEnded,
)
from hcss.platform.live.progress import (
    CurrentProbe,
    LogQueue,
    ProbeSchedule,
    ProgressMark,
    Projection,
)
from hcss.questionnaires.probes import ScheduledProbe
from hcss.simulation import Display, Simulation

if TYPE_CHECKING:
    from hcss.platform.live.leases import Fence


class ClockReading(Protocol):
    """A trial's clock as others read it (`clock.TrialClock`; `RunningTrial.trial_clock`)."""

    @property
    def paused_since(self) -> float | None:
        """When its clock stopped (a pause, or the database away); None while it runs."""

    @property
    def database_away_since(self) -> float | None:
        """When the database stopped taking its rows; None while it takes them."""

    def running_wall_s(self, now: float) -> float:
        """Wall seconds the trial clock has run: pauses do not count (live/clock.py)."""


class ProbesReading(Protocol):
    """A trial's probes as others read them (`progress.ProbeSchedule`; `RunningTrial.probes`)."""

    @property
    def plan(self) -> list[ScheduledProbe]: ...

    @property
    def shown(self) -> int: ...

    @property
    def current(self) -> CurrentProbe | None:
        """The probe on screen; None when none is."""

    def due(self, time: float) -> tuple[int, ScheduledProbe] | None:
        """The next planned probe (its 1-based index) if it is due at sim `time`."""


class LogReading(Protocol):
    """How far a trial's log is written (`progress.LogQueue`; `RunningTrial.log`)."""

    @property
    def decisions(self) -> int: ...

    @property
    def last_snapshot_epoch(self) -> float: ...

    @property
    def unwritten_events(self) -> list[EventHappened]: ...


class RunningTrial:
    """A trial being run in this server (the database row is `models.Trial`)."""

    def __init__(
        self,
        *,
        trial_id: int,
        participant_id: int,
        participant_code: str,
        participant_token: str,
        kind: str,
        model: str,
        seed: int,
        scenario_id: str,
        first_section: str | None,
        sim: Simulation,
        started_epoch: float,
        acceleration: float,
        duration_s: float,
        dt: float,
        probe_plan: list[ScheduledProbe],
        last_command_id: int | None = None,
    ) -> None:
        self.trial_id = trial_id
        self.participant_id = participant_id
        self.participant_code = participant_code
        # The link's secret: commands for a held trial are checked against it.
        self.participant_token = participant_token
        self.kind = kind
        self.model = model
        self.seed = seed
        self.scenario_id = scenario_id
        self.first_section = first_section
        self.dt = dt
        self.lock = threading.RLock()
        self.changed = threading.Condition(self.lock)
        self._sim = sim
        # The newest command the simulation holds (a snapshot names it).
        self._last_command_id = last_command_id
        self._clock = TrialClock(started_epoch, acceleration, duration_s)
        self._probes = ProbeSchedule(probe_plan)
        self._log = LogQueue()
        self._version = 0
        # Its lifecycle: read `ended`, `end_reason` and `moved`; written only by
        # `mark_ended` and `move_away`, with `lock` held.
        self._ended = False
        self._end_reason = ""
        self._moved = False
        #: With leases, the lease this trial was claimed with (`leases.Fence`): every unit of
        #: work that writes for it proves it first; None for a lone server.
        self.fence: Fence | None = None
        # System Messages so far, oldest first: {"seq", "time", "kind", "text"}.
        self._messages: list[dict[str, Any]] = []
        self._view_cache: tuple[int, Display, dict[str, Any], str] | None = None

    # --- what it is -----------------------------------------------------------

    @property
    def sim(self) -> Simulation:
        """The simulation; step it and apply commands to it with `lock` held."""
        return self._sim

    @property
    def started_epoch(self) -> float:
        """When the trial started (epoch seconds): the identity of its clock (`trial_clock` reads it)."""
        return self._clock.started_epoch

    @property
    def acceleration(self) -> float:
        return self._clock.acceleration

    @property
    def duration_s(self) -> float:
        return self._clock.duration_s

    # --- its read-only parts: how its clock, probes and log read now ------------------------

    @property
    def trial_clock(self) -> ClockReading:
        """Its clock (`clock.TrialClock`), to read: changed only by the trial's verbs below."""
        return self._clock

    @property
    def probes(self) -> ProbesReading:
        """Its probes (`progress.ProbeSchedule`), to read: changed only by the trial's verbs."""
        return self._probes

    @property
    def log(self) -> LogReading:
        """How far its log is written and what waits (`progress.LogQueue`), to read."""
        return self._log

    @property
    def log_queue(self) -> LogQueue:
        """Its log's queue (`progress.LogQueue`), for the recorder, the commands' units of work
        and the rebuild only, with `lock` held: what the simulation handed over waits there
        until a unit of work writes it, and its cursors move only with that unit's commit
        (`progress_mark`, `progress_lost`, `progress_written`)."""
        return self._log

    @property
    def version(self) -> int:
        """How often the state changed (`touch`): a stream sends a frame when it moved."""
        return self._version

    @property
    def messages(self) -> list[dict[str, Any]]:
        """The System Messages so far, oldest first; read-only (`add_message` adds one)."""
        return self._messages

    @property
    def last_command_id(self) -> int | None:
        return self._last_command_id

    # --- its lifecycle ----------------------------------------------------------

    @property
    def ended(self) -> bool:
        return self._ended

    @property
    def end_reason(self) -> str:
        """Why it ended (``time_limit``, ``aborted``, ``withdrawn``); "" while it runs."""
        return self._end_reason

    @property
    def moved(self) -> bool:
        """Another process hosts the trial now (this one lost its lease): streams close so
        the page reconnects to the host, and this copy is never written again."""
        return self._moved

    def leased(self, fence: Fence | None) -> None:
        """The trial is hosted under this lease (claimed for it); every write proves it."""
        self.fence = fence

    def mark_ended(self, reason: str) -> TrialEnded:
        """The trial is over for `reason`; call with `lock` held (streams wake on `touch`)."""
        self._ended, self._end_reason = True, reason
        return TrialEnded(reason, self._sim.step_count)

    def reopen(self) -> None:
        """Undo `mark_ended` whose row was not committed (the recorder's rollback)."""
        self._ended, self._end_reason = False, ""

    def move_away(self) -> None:
        """Another process hosts the trial from now on; wakes the streams so they close."""
        with self.lock:
            self._moved = True
            self.touch()

    # --- its clock (hcss.platform.live.clock) -----------------------------------

    @property
    def total_steps(self) -> int:
        return int(round(self.duration_s / self.dt))

    def due_step(self, now: float) -> int:
        """The step the wall clock says the trial should have reached."""
        elapsed = self._clock.running_wall_s(now) * self.acceleration
        return min(self.total_steps, int(math.floor(elapsed / self.dt + 1e-9)))

    def trial_time(self, now: float) -> float:
        """Trial time by the wall clock, for the page's timer (runs between steps)."""
        if self.ended:
            return self.duration_s
        return self._clock.trial_time_s(now)

    def pauses_restored(self, paused_s: float, paused_since: float | None) -> None:
        """The experimenter's pauses from the action log; call before stepping a loaded trial."""
        self._clock.pauses_restored(paused_s, paused_since)

    def stood_still(self, outage_s: float) -> None:
        """A server outage of `outage_s` wall seconds is over: the clock did not run in it."""
        self._clock.stood_still(outage_s)

    def paused(self, now: float) -> None:
        """The experimenter paused the trial at `now`; call with `lock` held, advanced to `now`."""
        if self._clock.pause(now):
            self.touch()

    def resumed(self, now: float) -> None:
        """The experimenter resumed it: the paused wall time never counts towards the trial."""
        if self._clock.resume(now):
            self.touch()

    def database_away(self, now: float) -> None:
        """The database refused the trial's rows: its clock stops here, as an outage stops it.

        The participant can neither command nor have anything recorded, so the
        trial must not run on; the rows of the batch that failed wait in memory
        (one batch at most, since the simulation steps no further).
        """
        if self._clock.database_away(now):
            self.touch()

    def database_back(self, now: float) -> None:
        """The held rows are written: the clock runs again from where it stood."""
        if self._clock.database_back(now):
            self.touch()

    # --- what the participant did -------------------------------------------------

    def command_applied(self, command_id: int) -> None:
        """The simulation holds the logged command `command_id` (the next snapshot says so)."""
        self._last_command_id = command_id

    def roll_back_to(self, snapshot: bytes) -> None:
        """Put the simulation back to `snapshot`: what changed it since was never logged."""
        self._sim = Simulation.restore(snapshot)

    # --- its probes (hcss.platform.live.progress.ProbeSchedule) ---------------------

    def probe_postponed(self, until: float) -> None:
        """No probe is shown before sim time `until` (the due one has no sensible subject yet)."""
        self._probes.postponed(until)

    def probe_shown(self, probe: CurrentProbe) -> None:
        """`probe` (its row written) is on screen from the next frame on."""
        self._probes.put_on_screen(probe)

    def probe_cleared(self) -> ProbeTimedOut | None:
        """The probe on screen (if any) timed out or the trial ended under it, now."""
        probe = self._probes.taken_off_screen()
        if probe is None:
            return None
        return ProbeTimedOut(probe.id, self._sim.step_count, float(self._sim.time))

    def probe_answered(self, answer: str) -> None:
        """The probe on screen is answered; a level-3 answer waits for the next decision."""
        self._probes.answered(answer)

    def projections_scored_by(self, decision: DecisionMade) -> list[ProjectionScored]:
        """The level-3 probes asked before `decision` ended, scored by it now."""
        return [
            ProjectionScored(
                probe_id,
                answer,
                decision.collective_name,
                self._sim.step_count,
                float(self._sim.time),
            )
            for probe_id, _shown_at, answer in self._probes.projections_ended_by(decision.end_s)
        ]

    def probes_restored(
        self, shown: int, current: CurrentProbe | None, projections: list[Projection]
    ) -> None:
        """The probes as their rows say, for a trial rebuilt after a restart."""
        self._probes.restored(shown, current, projections)

    # --- what is written to the trial log (progress.LogQueue; live.recorder) ---------------

    def progress_mark(self) -> ProgressMark:
        """What is counted written now, to go back to if the unit of work does not commit."""
        return ProgressMark(log=self._log.saved(), probes=self._probes.saved(), ended=self._ended)

    def progress_lost(self, mark: ProgressMark, *, handed_over_dropped: bool) -> None:
        """The unit of work begun at `mark` did not commit: its log, probes and end go back
        (`LogQueue.lost` says what happens to what was handed over)."""
        self._log.lost(mark.log, handed_over_dropped=handed_over_dropped)
        self._probes = mark.probes
        if self._ended and not mark.ended:
            self.reopen()  # its end was not written: it runs on

    def progress_written(self) -> None:
        self._log.written()

    # --- what the page sees ---------------------------------------------------------

    def touch(self) -> None:
        """Mark the state as changed and wake every stream; call with `lock` held."""
        self._version += 1
        self.changed.notify_all()

    def add_message(self, time: float, kind: str, text: str) -> None:
        seq = self._messages[-1]["seq"] + 1 if self._messages else 1
        self._messages.append(
            {"seq": seq, "time": round(float(time), 1), "kind": kind, "text": text}
        )

    def display(self) -> Display:
        """`sim.display()`, read once per state version (probes and actions share it)."""
        return self._cached_view()[0]

    def view(self) -> dict[str, Any]:
        """`sim.view()`, the display's JSON, once per state version; treat it as read-only."""
        return self._cached_view()[1]

    def view_json(self) -> str:
        return self._cached_view()[2]

    def _cached_view(self) -> tuple[Display, dict[str, Any], str]:
        if self._view_cache is None or self._view_cache[0] != self._version:
            display = self.sim.display()
            view = display.to_json()
            self._view_cache = (
                self._version,
                display,
                view,
                json.dumps(view, separators=(",", ":")),
            )
        return self._view_cache[1:]
