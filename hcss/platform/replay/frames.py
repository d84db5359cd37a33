"""A recorded trial rebuilt step by step, for watching it again.

The rebuild is the trial log's `build_simulation` (the simulation's own
deterministic replay from the trial's scenario, model, parameters and command
log); nothing is read from snapshots except, for comparison, the
digest the live trial recorded at its end. Each step's participant view is
kept as JSON, so a page that seeks back gets the same frames without
recomputing. A few rebuilt trials are kept in memory (least recently used
first out); a 20-minute trial is 1,200 steps of about 4 kB each.
"""

from __future__ import annotations

import json
import threading
from collections import OrderedDict
from dataclasses import dataclass, field

from sqlalchemy.orm import Session

from hcss.platform.live.trial_log import build_simulation, newest_snapshot
from hcss.platform.live.trials import latest_status
from hcss.platform.models import Trial, TrialStatusChange
from hcss.platform.models.latest import latest_row
from hcss.platform.models.vocabularies import TrialStatus
from hcss.simulation import NewerSnapshotFormat, Simulation

MAX_CHUNK = 300  # steps per frames request
CACHED_TRIALS = 4


@dataclass
class Recording:
    """How far the recording of a trial goes: its end, or its newest snapshot while live."""

    horizon: int  # the last step there is a frame for
    ended: bool
    recorded_digest: str | None  # the live simulation's state digest at `horizon`
    # Commands the replay may apply: all of them (None) for an ended trial; for a
    # live one, those already in its newest snapshot (ids up to this one).
    last_command_id: int | None


@dataclass
class ReplayRun:
    """One trial being rebuilt: the simulation so far and every step's view."""

    trial_id: int
    sim: Simulation | None = None
    frames: list[str] = field(default_factory=list)  # frames[k]: the view at step k
    lock: threading.Lock = field(default_factory=threading.Lock)

    def extend(
        self, session: Session, trial: Trial, through_command: int | None, until_step: int
    ) -> None:
        """Frames up to `until_step`; commands at a step are applied before it is drawn."""
        if len(self.frames) > until_step:
            return

        def draw(sim: Simulation) -> None:
            if sim.step_count == len(self.frames):  # the start's step is drawn already
                self.frames.append(json.dumps(sim.view(), separators=(",", ":")))

        self.sim = build_simulation(
            session,
            trial,
            until_step,
            start=self.sim,
            through_command=through_command,
            on_step=draw,
        )
        # A simulation that has finished stays as it is; its view is repeated.
        self.frames.extend(self.frames[-1:] * (until_step + 1 - len(self.frames)))


def recording_of(session: Session, trial: Trial) -> Recording:
    """An ended trial is replayed to its end; a live one to its newest snapshot.

    A live trial's later commands all come at or after its newest snapshot's
    step, so frames up to that step can never be changed by one still to come;
    a command applied at that very step after the snapshot is left for the
    next step, as the live simulation applied it.
    """
    snapshot = newest_snapshot(session, trial.id)
    digest = None if snapshot is None else _recorded_digest(snapshot.blob)
    if latest_status(session, trial.id) == TrialStatus.ENDED:
        end = latest_row(
            session,
            TrialStatusChange,
            TrialStatusChange.trial_id,
            trial.id,
            TrialStatusChange.status == TrialStatus.ENDED,
        )
        assert end is not None  # the latest status is ended
        if snapshot is None or snapshot.step != end.step:
            digest = None  # no snapshot was written at the end
        return Recording(end.step, ended=True, recorded_digest=digest, last_command_id=None)
    if snapshot is None:
        return Recording(0, ended=False, recorded_digest=None, last_command_id=0)
    return Recording(
        snapshot.step,
        ended=False,
        recorded_digest=digest,
        last_command_id=snapshot.last_command_id or 0,
    )


def _recorded_digest(blob: bytes) -> str | None:
    """The snapshot's digest; None for a newer version's format (nothing to compare it with)."""
    try:
        return Simulation.restore(blob).state_digest()
    except NewerSnapshotFormat:
        return None


class ReplayCache:
    """Rebuilt trials of this server process, shared by every replay page."""

    def __init__(self, size: int = CACHED_TRIALS) -> None:
        self.size = size
        self._runs: OrderedDict[int, ReplayRun] = OrderedDict()
        self._lock = threading.Lock()

    def run_for(self, trial: Trial) -> ReplayRun:
        with self._lock:
            run = self._runs.pop(trial.id, None)
            if run is None:
                run = ReplayRun(trial_id=trial.id)
            self._runs[trial.id] = run
            while len(self._runs) > self.size:
                self._runs.popitem(last=False)
            return run

    def chunk(self, session: Session, trial: Trial, start: int, count: int) -> str:
        """Frames `start` .. `start + count - 1` of the recording, as a JSON object.

        When the chunk reaches the recording's last step it carries the
        rebuilt state's digest there and the one the live trial recorded, so
        the page can show that the replay is the trial it claims to be.
        """
        recording = recording_of(session, trial)
        last = min(recording.horizon, start + max(1, min(count, MAX_CHUNK)) - 1)
        run = self.run_for(trial)
        replayed_digest = None
        with run.lock:
            frames: list[str] = []
            if start <= recording.horizon:
                run.extend(session, trial, recording.last_command_id, last)
                frames = run.frames[start : last + 1]
                if last == recording.horizon and run.sim is not None:
                    replayed_digest = run.sim.state_digest()
        head = {
            "start": start,
            "horizon": recording.horizon,
            "ended": recording.ended,
            "replayed_digest": replayed_digest,
            "recorded_digest": recording.recorded_digest if replayed_digest else None,
        }
        return (
            json.dumps(head, separators=(",", ":"))[:-1] + ',"frames":[' + ",".join(frames) + "]}"
        )
