"""A `RunningTrial`: one trial in memory, its simulation, lock, clock and what the page sees.

Everything that touches the simulation holds `lock`: the runner's steps, the
commands between them, and the stream reading a frame. `changed` wakes the
streams whenever the state moved, so a command's effect is sent at once.
"""

from __future__ import annotations

import json
import math
import threading
from dataclasses import dataclass, field
from typing import Any

from hcss.platform.live.clock import running_wall_s, trial_time_s
from hcss.platform.live.probes import probe_subject
from hcss.platform.models.vocabularies import TrialStatus
from hcss.questionnaires.probes import ScheduledProbe
from hcss.simulation import Display, Simulation
from hcss.simulation.requests import StatusChange


@dataclass
class CurrentProbe:
    """The probe on screen now (its `Probe` row id and what the page needs)."""

    id: int
    probe_index: int
    level: int
    question: str
    choices: list[str]
    truth: str | None
    shown_sim_time: float
    timeout_sim_time: float
    ready: bool = False
    # Running wall seconds (RunningTrial.running_wall_s) when the prompt, then the
    # question, was first sent to the page, and when Ready was pressed: the
    # latencies are measured from these. Lost in a restart: the first frame
    # after it delivers again.
    delivered_s: float | None = None
    question_delivered_s: float | None = None
    ready_s: float | None = None

    def delivered(self, running_s: float) -> None:
        """A frame carrying this probe is being sent."""
        if self.delivered_s is None:
            self.delivered_s = running_s
        if self.ready and self.question_delivered_s is None:
            self.question_delivered_s = running_s

    def public(self) -> dict[str, Any]:
        """What the browser sees: never the truth."""
        return {
            "id": self.id,
            "index": self.probe_index,
            "level": self.level,
            "phase": "question" if self.ready else "ready",
            "question": self.question if self.ready else None,
            "choices": self.choices if self.ready else None,
            "subject": probe_subject(self.level, self.question) if self.ready else None,
            "timeout_s": self.timeout_sim_time,
        }


@dataclass
class RunningTrial:
    """A trial being run in this server (the database row is `models.Trial`)."""

    trial_id: int
    participant_id: int
    participant_code: str
    participant_token: str  # the link's secret: commands for a held trial are checked against it
    kind: str
    model: str
    seed: int
    scenario_id: str
    first_section: str | None
    sim: Simulation
    started_epoch: float  # wall clock, seconds since the epoch
    acceleration: float
    duration_s: float
    dt: float
    lock: threading.RLock = field(default_factory=threading.RLock)
    version: int = 0
    # Its lifecycle: read `ended`, `end_reason` and `moved`; written only by
    # `mark_ended` and `move_away`, with `lock` held.
    _ended: bool = field(default=False, init=False)
    _end_reason: str = field(default="", init=False)
    _moved: bool = field(default=False, init=False)
    # System Messages so far, oldest first: {"seq", "time", "kind", "text"}.
    messages: list[dict[str, Any]] = field(default_factory=list)
    # (request id, status) pairs already written as RequestStatusChange rows.
    request_statuses_written: set[tuple[int, str]] = field(default_factory=set)
    decisions_recorded: int = 0
    last_event_time: float = -math.inf
    last_command_id: int | None = None
    last_snapshot_epoch: float = 0.0
    probe_plan: list[ScheduledProbe] = field(default_factory=list)
    probes_shown: int = 0
    postponed_until: float = 0.0
    current_probe: CurrentProbe | None = None
    # Level-3 probes waiting for the next decision: (probe id, shown time, answer or None).
    pending_projection: list[tuple[int, float, str | None]] = field(default_factory=list)
    # Experimenter pauses (hcss.platform.live.clock): wall seconds the
    # trial clock stood still, and the start of the pause under way, if any.
    paused_s: float = 0.0
    paused_since: float | None = None
    # What the simulation handed over (and the page was shown) that no commit has
    # written yet; the recorder writes it first, in order, when the database takes
    # writes again (hcss.platform.live.recorder.kept_until_written).
    unwritten_events: list[dict[str, Any]] = field(default_factory=list)
    unwritten_status_changes: list[StatusChange] = field(default_factory=list)
    # The wall instant the database stopped taking this trial's rows: the trial
    # clock stands still from then until they are written (hcss.platform.live.runner).
    database_away_since: float | None = None
    _view_cache: tuple[int, Display, dict[str, Any], str] | None = None

    def __post_init__(self) -> None:
        self.changed = threading.Condition(self.lock)

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

    def mark_ended(self, reason: str) -> None:
        """The trial is over for `reason`; call with `lock` held (streams wake on `touch`)."""
        self._ended, self._end_reason = True, reason

    def reopen(self) -> None:
        """Undo `mark_ended` whose row was not committed (the recorder's rollback)."""
        self._ended, self._end_reason = False, ""

    def move_away(self) -> None:
        """Another process hosts the trial from now on; wakes the streams so they close."""
        with self.lock:
            self._moved = True
            self.touch()

    @property
    def total_steps(self) -> int:
        return int(round(self.duration_s / self.dt))

    def due_step(self, now: float) -> int:
        """The step the wall clock says the trial should have reached."""
        elapsed = self.running_wall_s(now) * self.acceleration
        return min(self.total_steps, int(math.floor(elapsed / self.dt + 1e-9)))

    def running_wall_s(self, now: float) -> float:
        """Wall seconds the trial clock has run: pauses do not count (live/clock.py)."""
        return running_wall_s(self.started_epoch, self.paused_s, self.paused_since, now)

    def clock(self, now: float) -> float:
        """Trial time by the wall clock, for the page's timer (runs between steps)."""
        if self.ended:
            return self.duration_s
        return trial_time_s(
            self.started_epoch,
            self.paused_s,
            self.paused_since,
            now,
            acceleration=self.acceleration,
            duration_s=self.duration_s,
        )

    def touch(self) -> None:
        """Mark the state as changed and wake every stream; call with `lock` held."""
        self.version += 1
        self.changed.notify_all()

    def add_message(self, time: float, kind: str, text: str) -> None:
        seq = self.messages[-1]["seq"] + 1 if self.messages else 1
        self.messages.append(
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
        if self._view_cache is None or self._view_cache[0] != self.version:
            display = self.sim.display()
            view = display.to_json()
            self._view_cache = (
                self.version,
                display,
                view,
                json.dumps(view, separators=(",", ":")),
            )
        return self._view_cache[1:]

    def frame(self, now: float, after_seq: int) -> tuple[str, int]:
        """One stream frame (JSON text) and the newest message seq it carries."""
        if self.current_probe is not None:
            self.current_probe.delivered(self.running_wall_s(now))
        new_messages = [m for m in self.messages if m["seq"] > after_seq]
        last_seq = new_messages[-1]["seq"] if new_messages else after_seq
        head = {
            "trial": {
                "id": self.trial_id,
                "kind": self.kind,
                # The page's status: the trial's, or "paused" while the experimenter holds it.
                "status": TrialStatus.ENDED
                if self.ended
                else ("paused" if self.paused_since is not None else TrialStatus.RUNNING),
                "clock_s": round(self.clock(now), 2),
                "duration_s": self.duration_s,
                "step": self.sim.step_count,
                "version": self.version,
                # Why a pause the experimenter did not make: the database is away.
                "held_by": None if self.database_away_since is None else "database",
                # Why it ended ("time_limit", "aborted"): the page words it.
                "end_reason": self.end_reason if self.ended else None,
            },
            "messages": new_messages,
            "probe": None if self.current_probe is None else self.current_probe.public(),
        }
        text = json.dumps(head, separators=(",", ":"))
        return text[:-1] + ',"view":' + self.view_json() + "}", last_seq
