"""The runner: the registry of live trials, and the thread that keeps them on time.

Each tick it finds trials the database says are running (started here, by the
CLI, or before a restart), advances each to the step the wall clock says is
due, records what happened and wakes the streams. Commands do not wait for a
tick: they take the trial's lock and apply between two steps.

Blueprints use only the public methods below (host, loaded, holding, pause,
resume, end, finish_overdue, forget, withdrawing, commanding, let_go, holds_for); the registry and
its lock are private. The thread is started only where trials are served
(`hcss serve`, the test server); an app built for a script or a check has a
runner without one.

With several processes, the runner also hands a trial back to its home (the
process nginx sends its participant to) once, when that process restarted
after this one took the trial over (`send_home`, see hcss.platform.live.leases),
and over to a process that withdraws it; how is hcss.platform.live.hand_back. How one trial is stepped and recorded is
hcss.platform.live.stepping.
"""

from __future__ import annotations

import hmac
import logging
import threading
import time as wallclock
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from typing import TYPE_CHECKING

from sqlalchemy.exc import DBAPIError
from sqlalchemy.orm import Session

from hcss.platform.db import Database
from hcss.platform.errors import database_away
from hcss.platform.live.hand_back import hand_back, hand_over
from hcss.platform.live.leases import Fence, HostedElsewhere, Leases
from hcss.platform.live.orders import (
    HAND_OVER,
    POLL_S,
    PendingOrder,
    pending_orders,
    send_order,
)
from hcss.platform.live.recorder import (
    end_trial,
)
from hcss.platform.live.stepping import advance_trial
from hcss.platform.live.takeover import take_up
from hcss.platform.live.trials import running_trial_ids

if TYPE_CHECKING:
    from hcss.platform.live.running_trial import RunningTrial

log = logging.getLogger(__name__)

TICK_S = 0.05
SYNC_EVERY_S = 1.0


class Runner:
    def __init__(
        self,
        database: Database,
        *,
        snapshot_interval_s: float = 5.0,
        leases: Leases | None = None,
        carry_out_order: Callable[[Database, Runner, PendingOrder], object],
    ) -> None:
        self.database = database
        #: The live service's door, through which a console's order for a trial hosted
        #: here is carried out as a console served here would carry it out.
        self._carry_out_order = carry_out_order
        #: None: this process hosts every running trial; else only those it holds the lease of.
        self.leases = leases
        self._last_renewal = -float("inf")
        self._last_orders = -float("inf")  # monotonic
        self.snapshot_interval_s = snapshot_interval_s
        self._trials: dict[int, RunningTrial] = {}
        self._registry_lock = threading.RLock()
        self._loading: dict[int, threading.Lock] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        #: Renews the leases on its own thread, so no rebuild or slow write delays a renewal.
        self._keeper: threading.Thread | None = None
        self._last_sync = -float("inf")
        self._told_unmigrated = False
        #: The database refused the last sync (an outage, said once in the log until it ends).
        self._database_away = False
        #: Participants' commands under way per trial (`commanding`): no hand-back meanwhile.
        self._commanding: Counter[int] = Counter()
        #: Trials held here whose home restarted (found at the last renewal): id -> its process.
        self._going_home: dict[int, str] = {}

    @property
    def clock(self) -> Callable[[], float]:
        """The database's clock (epoch seconds): trials step by the clock that stamps their rows."""
        return self.database.clock

    @clock.setter
    def clock(self, clock: Callable[[], float]) -> None:
        self.database.clock = clock

    # --- finding trials -------------------------------------------------------

    def host(self, trial_id: int, *, participant: bool = False) -> RunningTrial | None:
        """Host the trial here: the trial in memory, claimed and rebuilt first if the
        database says it is running and it is not in memory (None: it is not running).

        With leases, hosting means taking the trial's lease first (a takeover
        when its owner died); `HostedElsewhere` naming the holder when another
        live process holds it, or naming the trial's home when nobody holds it
        and its home is another live member: a participant's request is
        forwarded there, the trial does not move (hcss.platform.live.leases,
        Placement). `participant` is kept for the callers; it changes nothing
        now. `loaded` only looks.
        """
        live = self._trials.get(trial_id)
        if live is not None:
            return live
        # One loader per trial, not one for the registry: a rebuild of one trial never
        # holds up the streams, commands and lease renewals of the others.
        with self._registry_lock:
            loading = self._loading.setdefault(trial_id, threading.Lock())
        with loading:
            live = self._trials.get(trial_id)
            if live is not None:
                return live
            live = take_up(self, trial_id)
            if live is not None:
                with self._registry_lock:
                    self._trials[trial_id] = live
            return live

    def hosts(self, trial_id: int) -> bool:
        """Whether this process may host the trial now (always, without leases)."""
        try:
            return self.host(trial_id) is not None
        except HostedElsewhere:
            return False

    def loaded(self, trial_id: int) -> RunningTrial | None:
        """The live trial if this process holds it in memory; never loads it."""
        with self._registry_lock:
            return self._trials.get(trial_id)

    def holds_for(self, token: str, trial_id: int) -> bool:
        """Whether this process holds the trial in memory for this token; False: ask the
        database.

        The live API's looks and commands come several times a second per trial;
        checking a held trial's owner in memory spares each of them a query and a
        transaction. A trial not held, or held for another token, goes the
        database's way, so every answer (404, 409) is the same either way.
        """
        live = self.loaded(trial_id)
        return live is not None and hmac.compare_digest(
            live.participant_token.encode(), token.encode()
        )

    def loaded_ids(self) -> set[int]:
        """Ids of the trials held in memory (for tests and the console)."""
        with self._registry_lock:
            return set(self._trials)

    def forget(self, trial_id: int) -> RunningTrial | None:
        """End: drop a trial from memory (it ended, or its memory is no longer trusted) and
        release its lease; the next `host` rebuilds it from the database if it is running."""
        with self._registry_lock:
            live = self._trials.pop(trial_id, None)
        if live is not None:
            self.release_lease(trial_id)
        return live

    def release_lease(self, trial_id: int) -> None:
        """Give up the trial's lease so another process need not wait for it to run out."""
        if self.leases is None:
            return
        try:
            self.leases.release(trial_id)
        except DBAPIError:
            log.warning("could not release the lease of trial %s; it runs out by itself", trial_id)

    @contextmanager
    def commanding(self, trial_id: int) -> Iterator[None]:
        """A participant's command for the trial is under way (found, waiting for the lock,
        applied, written): the trial is not handed to another process meanwhile."""
        with self._registry_lock:
            self._commanding[trial_id] += 1
        try:
            yield
        finally:
            with self._registry_lock:
                self._commanding[trial_id] -= 1
                if self._commanding[trial_id] <= 0:
                    del self._commanding[trial_id]

    def commands_under_way(self, trial_id: int) -> bool:
        """Whether a participant's command for the trial is under way (`commanding`)."""
        with self._registry_lock:
            return self._commanding[trial_id] > 0

    # --- stopping hosting: one verb per reason (docs/architecture.md) ---------------
    # end: `forget`; hand-over: `let_go`; crash: `lose`. The trial's side of the last
    # two is `RunningTrial.move_away`, of the first `RunningTrial.mark_ended`.

    def let_go(self, live: RunningTrial) -> None:
        """Hand-over: stop hosting this copy of the trial, whose lease this process passed
        to another in a fenced unit of work (a hand back home, a hand-over to a process
        withdrawing it): it leaves the registry, its lease is not released here."""
        with self._registry_lock:
            if self._trials.get(live.trial_id) is live:
                del self._trials[live.trial_id]
        live.move_away()  # its streams close; the page reconnects, to the new host

    def lose(self, trial_id: int, fence: Fence) -> None:
        """Crash: stop hosting a trial whose lease (claimed with `fence`) was lost, to a stall
        or a partition longer than the lease; another process may host it now. A copy
        claimed again meanwhile, under a new epoch, stays."""
        with self._registry_lock:
            lost = self._trials.get(trial_id)
            if lost is None or lost.fence is not fence:
                return
            del self._trials[trial_id]
        lost.move_away()  # it writes nothing more; its streams close, the page reconnects

    # --- controlling one trial --------------------------------------------------

    @contextmanager
    def holding(
        self, live: RunningTrial, now: float, *, advance: bool = True
    ) -> Iterator[RunningTrial]:
        """Hold the trial's lock; first advance it to `now`, so its clock stops at this instant."""
        with live.lock:
            if advance:
                self.advance(live, now)
            yield live

    def pause(self, live: RunningTrial, now: float) -> None:
        """Stop the trial clock at `now` (call inside `holding`)."""
        live.paused(now)

    def resume(self, live: RunningTrial, now: float) -> None:
        """Restart the trial clock; the paused wall time never counts (call inside `holding`)."""
        live.resumed(now)

    def end(self, live: RunningTrial, session: Session, reason: str, now: float) -> None:
        """End the trial with `reason`, written in `session` (call inside `holding`)."""
        end_trial(live, session, reason, now)
        live.touch()

    def finish_overdue(self, trial_id: int) -> None:
        """Step a trial past its deadline to its end, recording everything on the way.

        Only its host does: a trial hosted by another process ends there.
        """
        try:
            live = self.host(trial_id)
        except HostedElsewhere:
            return
        if live is None:
            return
        self.advance(live, self.clock())
        if live.ended:
            self.forget(trial_id)

    @contextmanager
    def withdrawing(self, trial_ids: list[int], reason: str) -> Iterator[None]:
        """Hold the locks of these trials while their rows are deleted; then end and forget them.

        No runner step or command can write a row for the trials meanwhile; a
        trial loaded by another thread during the deletion is dropped too.
        With leases, this process first holds the lease of each (a trial
        another process hosts is handed over), so no other process writes either.
        """
        if self.leases is not None:
            self._take_hold(trial_ids)
        with self._registry_lock:
            held = [self._trials[t] for t in trial_ids if t in self._trials]
        with ExitStack() as stack:
            for live in held:
                stack.enter_context(live.lock)
            yield
            for live in held:
                live.mark_ended(reason)
                live.touch()
            for trial_id in trial_ids:
                stale = self.forget(trial_id)
                if stale is not None:
                    stale.mark_ended(reason)
                self.release_lease(trial_id)  # held for the deletion, never loaded

    def sync(self) -> None:
        """Load every running trial not yet in memory (after a restart, or from the CLI)."""
        with self.database.session_scope() as session:
            running = running_trial_ids(session)
        self._told_unmigrated = False  # the tables are there (again)
        missing = [t for t in running if t not in self._trials]
        budget_s = float("inf")
        if self.leases is not None:  # take over only what nobody hosts
            missing = self.leases.to_take(missing, self.clock())
            # In batches shorter than a renewal period: the trials held here advance between
            # two batches, so a survivor taking over many trials never stops its own clocks
            # for long (the leases are renewed on their own thread meanwhile).
            budget_s = self.leases.renew_every_s
        started = wallclock.monotonic()
        for trial_id in missing:
            if wallclock.monotonic() - started >= budget_s:
                break  # the rest at the next sync
            if trial_id not in self._trials:
                try:
                    self.host(trial_id)
                except Exception as error:
                    if database_away(error):
                        raise  # the others would fail alike: the tick says it once
                    log.exception("could not load live trial %s", trial_id)
        self._database_away = False

    # --- advancing --------------------------------------------------------------

    def tick(self) -> None:
        """Bring every live trial up to the wall clock; the thread calls this in a loop."""
        now = self.clock()
        renewing_here = self._keeper is None  # else the lease keeper's thread renews
        if (
            self.leases is not None
            and renewing_here
            and now - self._last_renewal >= self.leases.renew_every_s
        ):
            self._renew(now)
        if now - self._last_sync >= SYNC_EVERY_S:
            self._last_sync = now
            try:
                self.sync()
            except Exception as error:
                if not database_away(error) or _missing_table(error):
                    raise
                # The database is away (or read-only): the trials in memory still advance,
                # and their failing writes stop their clocks until it is back. One WARNING
                # line per outage, as the request path says it (errors.log_database_away).
                self._say_away(error)
        if self.leases is not None and wallclock.monotonic() - self._last_orders >= POLL_S:
            self._last_orders = wallclock.monotonic()
            self.carry_out_orders()
        if self._going_home:
            self.send_home()
        with self._registry_lock:
            live_trials = list(self._trials.values())
        for live in live_trials:
            try:
                self.advance(live, now)
            except Exception:
                log.exception("live trial %s failed to advance", live.trial_id)
            if live.ended or live.moved:
                # Moved without leaving the registry: its memory is not to be trusted (a
                # command's commit that nobody can say landed); the next `host` rebuilds it.
                self.forget(live.trial_id)

    def carry_out_orders(self) -> None:
        """Carry out the console orders other processes wrote for trials hosted here."""
        for order in pending_orders(self.database, self.loaded_ids()):
            live = self.loaded(order.trial_id)
            if live is None:
                continue
            try:
                if order.action == HAND_OVER:
                    hand_over(self, live, order)
                    continue
                self._carry_out_order(self.database, self, order)
            except Exception:
                log.exception("console order %s for trial %s failed", order.id, order.trial_id)

    def send_home(self) -> None:
        """Hand the trials whose home restarted (found at the last renewal) to it, each at a
        safe point; one busy now (a command under way, its lock taken) waits for a tick."""
        with self._registry_lock:
            going = list(self._going_home.items())
        for trial_id, heir in going:
            live = self.loaded(trial_id)
            try:
                done = live is None or hand_back(self, live, heir)
            except Exception:
                log.exception("live trial %s could not be handed to %s", trial_id, heir)
                done = True  # found again at the next renewal if it still is to go
            if done:
                with self._registry_lock:
                    if self._going_home.get(trial_id) == heir:
                        del self._going_home[trial_id]

    def _take_hold(self, trial_ids: list[int]) -> None:
        """Make this process the holder of every lease of these trials (for a withdrawal).

        A trial no process hosts is claimed; one another process hosts is asked
        for by a hand-over order. Then no other process can write a row for
        them while they are deleted here.
        """
        assert self.leases is not None
        for trial_id in trial_ids:
            if trial_id in self._trials or self.leases.claim(trial_id, self.clock()) is not None:
                continue
            outcome = send_order(
                self.database,
                trial_id,
                HAND_OVER,
                experimenter_id=None,
                issued_by=self.leases.owner,
            )
            if outcome is None:
                raise HostedElsewhere(trial_id, self.leases.holder(trial_id, self.clock()) or "")

    def _renew(self, now: float) -> None:
        """Renew the leases of every trial held; stop hosting any whose lease was lost.

        A lease is lost when this process could not renew it in time (a stall,
        or a database outage longer than the lease), and another process may
        host the trial now: writing for it from here would fork its record.
        Until a renewal answers, each trial's own deadline (`Fence.holds`)
        keeps it from writing once the lease may have run out.
        """
        assert self.leases is not None
        with self._registry_lock:
            held = {
                trial_id: live.fence
                for trial_id, live in self._trials.items()
                if live.fence is not None
            }
        started = self.leases.monotonic()
        try:
            kept, going = self.leases.renew_and_look_home(
                {t: f.epoch for t, f in held.items()}, now
            )
        except DBAPIError:
            if now - self._last_renewal < self.leases.lease_s:
                log.debug("lease renewal failed; the next tick tries again", exc_info=True)
                return
            kept = set()  # the database was away longer than a lease: another may host them
        else:
            self._last_renewal = now
            with self._registry_lock:
                self._going_home = going
        deadline = self.leases.deadline_after(started)
        for trial_id in kept:
            held[trial_id].deadline = max(held[trial_id].deadline, deadline)
        for trial_id in set(held) - kept:
            log.warning("lost the lease of live trial %s; another process hosts it", trial_id)
            self.lose(trial_id, held[trial_id])

    def advance(self, live: RunningTrial, now: float) -> None:
        """Step the trial to the step due at `now`, record it, end it at its time limit
        (`stepping.advance_trial`)."""
        advance_trial(self.database, live, now, snapshot_interval_s=self.snapshot_interval_s)

    def start(self) -> None:
        if self._thread is not None:
            return
        if self.leases is not None:
            self._keeper = threading.Thread(
                target=self._keep_leases, name="hcss-lease-keeper", daemon=True
            )
            self._keeper.start()
        self._thread = threading.Thread(target=self._run, name="hcss-live-runner", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        for thread in (self._thread, self._keeper):
            if thread is not None:
                thread.join(timeout=5)
        self._thread = self._keeper = None

    def _say_away(self, error: BaseException) -> None:
        """One WARNING line per outage (as the request path says it, errors.log_database_away),
        not a traceback per trial and tick: the log tells an outage from a bug."""
        if not self._database_away:
            self._database_away = True
            log.warning("live runner: %s; trials are taken up once it is back", _why(error))

    def _keep_leases(self) -> None:
        """Renew the held leases a few times per lease length, whatever the runner is doing."""
        assert self.leases is not None
        while not self._stop.is_set():
            try:
                self._renew(self.clock())
            except Exception:
                log.exception("lease renewal failed")
            self._stop.wait(self.leases.renew_every_s)

    def _run(self) -> None:
        while not self._stop.is_set():
            started = wallclock.monotonic()
            try:
                self.tick()
            except Exception as error:
                if isinstance(error, DBAPIError) and _missing_table(error):
                    if not self._told_unmigrated:  # one clear line, not a traceback every tick
                        self._told_unmigrated = True
                        log.error(
                            "the database has no platform tables (run `hcss db upgrade`); "
                            "the live runner waits for them"
                        )
                elif database_away(error):
                    self._say_away(error)
                else:
                    log.exception("runner tick failed")
            self._stop.wait(max(0.0, TICK_S - (wallclock.monotonic() - started)))


def _why(error: BaseException) -> str:
    """An outage in one line: the driver's own first words."""
    cause = getattr(error, "orig", None) or error
    words = str(cause).strip().splitlines()[0][:200] if str(cause).strip() else ""
    return f"the database is away: {type(cause).__name__}: {words}"


def _missing_table(error: BaseException) -> bool:
    """SQLite says "no such table", PostgreSQL "relation ... does not exist"."""
    text = str(getattr(error, "orig", error)).lower()
    return "no such table" in text or ("relation" in text and "does not exist" in text)
