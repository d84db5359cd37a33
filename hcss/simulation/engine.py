"""The Simulation: one trial of collectives choosing sites.

`step()` runs the rules in a fixed order, each a compiled function over all
agents (fused into two calls, `step.py`): move, arrive, enforce standing
orders, discover, rate transitions, serve requests, exchange messages; then,
in Python and only when something happened, begin moves and end decisions.
Randomness comes from the scenario's seed and the run number: the compiled
rules draw from the World's own stream (`stream.py`), the Python-side request
handling from one `numpy.random.Generator`; both are part of the state, and
requests are applied between steps, so the same scenario, run and timed
request log reproduce a run bit for bit.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import asdict
from types import SimpleNamespace
from typing import Any

import numpy as np

from hcss.simulation import decisions as dec
from hcss.simulation import movement, rules
from hcss.simulation import states as S
from hcss.simulation.constants import constants_for
from hcss.simulation.errors import SimulationError
from hcss.simulation.ids import target_id, target_index
from hcss.simulation.params import MODELS, Params
from hcss.simulation.requests import (
    COMPLETED,
    IN_PROGRESS,
    REMOVED,
    OperatorCommand,
    Request,
    RequestOutcome,
    StatusChange,
    recruit_for,
    refusal,
)
from hcss.simulation.scenario import Scenario
from hcss.simulation.snapshots import stamped, unstamped
from hcss.simulation.step import ADVANCE, EXCHANGE, WHOLE, steps
from hcss.simulation.view import Display, Truth, display_of, truth_of
from hcss.simulation.world import World

DERIVED = ("rng", "scenario", "params", "_k", "_scratch")  # not pickled as such


class Simulation:
    """A trial: collectives, targets, requests and the records of their decisions."""

    def __init__(
        self, scenario: Scenario, model: str = "M1", params: Params | None = None, run: int = 0
    ):
        if model not in MODELS:
            raise SimulationError(f"model must be one of {', '.join(MODELS)}, not {model!r}")
        self.scenario = scenario
        self.model = model
        self.params = params or Params()
        self.run = int(run)
        self.rng = np.random.default_rng(
            np.random.SeedSequence(scenario.seed, spawn_key=(1, self.run))
        )
        self.world = World.new(scenario, self.params, run=self.run)
        self._prepare()
        self.requests: list[Request] = []
        self.decisions: list[dec.DecisionRecord] = []
        self.open: list[dec.OpenDecision | None] = [None] * scenario.n_collectives
        self.decision_counts = [0] * scenario.n_collectives
        self.next_request_id = 1
        self.commands_applied = (
            0  # every command, accepted or refused: a replay's position in its log
        )
        self.events: list[dict[str, Any]] = []
        self.status_changes: list[StatusChange] = []  # drained by drain_status_changes
        self._start_section(0)

    def _prepare(self) -> None:
        """The kernels' constants and scratch buffers (derived, rebuilt on restore)."""
        w = self.world
        self._k = constants_for(self.params, self.model)
        self._scratch = SimpleNamespace(
            at_target=np.empty(w.state.size, dtype=np.int64),
            at_hub=np.empty(w.state.size, dtype=np.int64),
            visible=np.empty(w.active.size, dtype=np.int64),
            finished=np.zeros(w.n_collectives, dtype=np.bool_),
            counts=np.zeros(len(S.NAMES), dtype=np.int64),
            committed=np.zeros(w.abandon_order.shape, dtype=np.int64),
            moving=np.zeros(w.abandon_order.shape, dtype=np.int64),
        )

    # ------------------------------------------------------------------ clock
    @property
    def time(self) -> float:
        return self.world.time

    @property
    def step_count(self) -> int:
        return self.world.step_count

    @property
    def finished(self) -> bool:
        return self.world.finished

    def step(self, n: int = 1) -> None:
        """Advance n steps of dt seconds (fewer if the trial finishes)."""
        self._advance(self.world.step_count + n)

    def run_until_finished(self, max_steps: int | None = None) -> None:
        self._advance(max_steps if max_steps is not None else 10**9)

    def _advance(self, until_step: int) -> None:
        """Step until `until_step` or the end of the trial.

        Steps in which nothing needs Python (no discovery to announce, no new
        commitment, no move to begin, no decision ending or timing out, no
        request waiting for agents) run inside one compiled call, exactly as
        they would one by one.
        """
        w = self.world
        while not w.finished and w.step_count < until_step:
            if any(r.needed and r.active for r in self.requests):
                self._step_once()
                continue
            budget = min(until_step, self._timeout_step()) - w.step_count
            done, n_visible = self._steps(max(1, budget), WHOLE)
            w.step_count += done - 1  # the last step's bookkeeping follows
            self._after_step(n_visible)

    def _timeout_step(self) -> int:
        """The first step count at which an open decision reaches the time limit."""
        limit, dt = self.params.decision_timeout_s, self.params.dt_s
        if limit is None:
            return 10**18
        first = 10**18
        for decision in self.open:
            if decision is not None:
                step = math.ceil((decision.start_s + limit) / dt)
                while step > 0 and (step - 1) * dt - decision.start_s >= limit:
                    step -= 1
                while step * dt - decision.start_s < limit:
                    step += 1
                first = min(first, step)
        return first

    def _steps(self, max_steps: int, part: int) -> tuple[int, int]:
        """The compiled step (`step.steps`) on this trial's arrays and scratch buffers."""
        w, scratch = self.world, self._scratch
        done, visible = steps(
            w.kernel_arrays(),
            self._k,
            scratch.at_target,
            scratch.at_hub,
            scratch.visible,
            scratch.finished,
            scratch.counts,
            scratch.committed,
            scratch.moving,
            w.commit_announced,
            w.executing,
            max_steps,
            part,
        )
        return int(done), int(visible)

    def _step_once(self) -> None:
        """One step in two halves, serving the requests that wait for agents in between."""
        _, n_visible = self._steps(1, ADVANCE)
        for request in self.requests:
            recruit_for(self.world, request, self.rng)
        self._steps(1, EXCHANGE)
        self._after_step(n_visible)

    def _after_step(self, n_visible: int) -> None:
        """What follows a step in Python: events, commitments, moves, decisions ending."""
        w, scratch = self.world, self._scratch
        w.step_count += 1
        w.time = w.step_count * self.params.dt_s
        if self.requests:
            self._note_completed()
        for t in scratch.visible[:n_visible].tolist():
            self._event("discovery", None, t)
        if scratch.counts[S.C]:
            self._announce_commitments()
        if scratch.counts[S.X] and (w.executing < 0).any():
            self._begin_moves()
        if scratch.finished.any():
            section = w.section
            for c in np.flatnonzero(scratch.finished):
                # A decision that completes the section discards the others under way,
                # including any that reached their quorum in this same step.
                if w.finished or w.section != section:
                    break
                if self.open[c] is not None and w.executing[c] >= 0:
                    self._end_decision(int(c))
        self._time_out_decisions()

    # -------------------------------------------------------------- requests
    def apply(self, command: OperatorCommand) -> RequestOutcome:
        """Apply one operator command: investigate, abandon, decide or cancel.

        Every command is counted, refused or not, so that a replay from a
        snapshot knows how much of the command log the snapshot contains.
        Anything but an `OperatorCommand` of a known kind is refused.
        """
        self.commands_applied += 1
        if not isinstance(command, OperatorCommand):
            return RequestOutcome(False, reason="A command must be an OperatorCommand.")
        if command.kind == "cancel":
            return self._cancel(command.request_id)
        if command.kind not in ("investigate", "abandon", "decide"):
            return RequestOutcome(False, reason=f"Unknown request type {command.kind!r}.")
        return self._request(command.kind, command.collective, command.target)

    def investigate(self, collective: int, target: int) -> RequestOutcome:
        return self.apply(OperatorCommand("investigate", collective, target))

    def abandon(self, collective: int, target: int) -> RequestOutcome:
        return self.apply(OperatorCommand("abandon", collective, target))

    def decide(self, collective: int, target: int) -> RequestOutcome:
        return self.apply(OperatorCommand("decide", collective, target))

    def cancel_abandon(self, request_id: int) -> RequestOutcome:
        return self.apply(OperatorCommand.cancel(request_id))

    def _cancel(self, request_id: object) -> RequestOutcome:
        """Lift a standing abandon order; only an abandon can be cancelled."""
        for request in self.requests:
            if request.id == _as_int(request_id) and request.kind == "abandon" and request.active:
                c, t = request.collective, request.target
                context = self._context(c, t)
                request.active = False
                self.world.abandon_order[c, t] = False
                self._remove_request(request)
                self._count_request("cancel", c, False)
                return RequestOutcome(True, request.id, "", c, target_id(t), *context)
        return RequestOutcome(False, reason=f"There is no active abandon assignment {request_id}.")

    def _request(self, kind: str, collective: object, target: object) -> RequestOutcome:
        c, t_id = _as_int(collective), _as_int(target)
        if c is None or t_id is None:
            return RequestOutcome(
                False,
                reason="A request needs a collective and a target.",
                collective=c,
                target=t_id,
            )
        w, p = self.world, self.params
        t = target_index(t_id)
        support, decision_index = self._context(c, t)
        reason = refusal(w, p, kind, c, t)
        if reason:
            return RequestOutcome(False, None, reason, c, t_id, support, decision_index)
        assert support is not None  # a request is refused unless the operator sees the target
        needed = {"investigate": p.investigate_agents, "decide": p.decide_agents}.get(kind, 0)
        request = Request(self.next_request_id, kind, c, t, needed, support=support)
        self.next_request_id += 1
        self.requests.append(request)
        if kind == "abandon":
            w.abandon_order[c, t] = True
            rules.enforce_orders(w, p)
        self._note_status(request, IN_PROGRESS)
        recruit_for(w, request, self.rng)
        self._note_completed()
        intervention = kind == "abandon" and support >= p.intervention_support
        self._count_request(kind, c, intervention)
        return RequestOutcome(True, request.id, "", c, t_id, support, decision_index, intervention)

    def _context(self, c: int, t: int) -> tuple[float | None, int | None]:
        """(support, decision index) of collective `c` and target index `t` before a command.

        Support only for a target the operator can see (as the interface shows it).
        """
        w, p = self.world, self.params
        if not 0 <= c < w.n_collectives:
            return None, None
        decision = self.open[c]
        index = None if decision is None else decision.index
        if not (0 <= t < w.active.size and w.active[t] and w.report_count[t] >= p.visible_reports):
            return None, index
        return float(w.support()[c, t]), index

    def _count_request(self, kind: str, collective: int, intervention: bool) -> None:
        decision = self.open[collective]
        if decision is not None:
            decision.requests[kind] += 1
            decision.requests["interventions"] += int(intervention)

    def _note_status(self, request: Request, status: str) -> None:
        """Queue a request's new status for `drain_status_changes`."""
        request.noted = status
        self.status_changes.append(
            StatusChange(request.id, status, self.world.step_count, self.world.time)
        )

    def _note_completed(self) -> None:
        """Queue the requests that have just got all the agents they needed."""
        for request in self.requests:
            if request.status == COMPLETED and request.noted != COMPLETED:
                self._note_status(request, COMPLETED)

    def _remove_request(self, request: Request) -> None:
        """The request leaves the Collective Assignments list."""
        self.requests.remove(request)
        self._note_status(request, REMOVED)

    # ------------------------------------------------------------ observing
    def display(self) -> Display:
        """What the Collective Interface shows (spec §9), as read-only arrays; never the truth."""
        return display_of(self)

    def view(self) -> dict[str, Any]:
        """The display as JSON-able values, for the browser (`Display.to_json`)."""
        return self.display().to_json()

    def truth(self) -> Truth:
        """What the operator cannot see: true target values, each collective's best target.

        The only source of truth for scoring answers (the platform's probes).
        """
        return truth_of(self)

    def drain_events(self) -> list[dict[str, Any]]:
        """Events since the last call (discoveries, commitments, moves, arrivals...), typed;
        `hcss.simulation.messages.event_text` words each as a System Message."""
        events, self.events = self.events, []
        return events

    def drain_status_changes(self) -> list[StatusChange]:
        """Each request's status changes since the last call, oldest first."""
        changes, self.status_changes = self.status_changes, []
        return changes

    def best_target(self, collective: int) -> int | None:
        """The best available target id for a collective: the truth for level-2 probes."""
        return self.truth().best_for(collective)

    def _event(
        self, kind: str, collective: int | None, index: int | None, section: int | None = None
    ) -> None:
        """Queue a typed event; `index` is the target's array index, stored as its public id.

        The words are not the model's: `hcss.simulation.messages.event_text` gives them.
        """
        target = None if index is None else target_id(index)
        event: dict[str, Any] = {
            "time": self.world.time,
            "kind": kind,
            "collective": collective,
            "target": target,
        }
        if section is not None:
            event["section"] = section  # 1-based, as the participant counts sections
        self.events.append(event)

    # ------------------------------------------------------------ decisions
    def _start_section(self, section: int) -> None:
        w = self.world
        w.section, w.decisions_in_section = section, 0
        w.active[:] = w.target_section == section
        w.reserved_by[:] = -1
        w.hub[:] = w.start_hub
        rules.refresh_geometry(w, self.params)
        w.abandon_order[:] = False
        w.executing[:] = -1
        w.commit_announced[:] = -1
        everyone = np.arange(w.state.size)
        w.set_state(everyone, S.U_I)
        w.leg[:] = S.AT_HUB
        w.arrival_state[:] = S.U_I
        w.report_target[:] = -1
        w.streak[:] = 0
        w.silence[:] = 0.0
        w.reported_quadrant[:] = 0
        movement.scatter_in_hub(w, everyone, self._k)
        for request in list(self.requests):
            self._remove_request(request)
        for c in range(w.n_collectives):
            self._open_decision(c, self.scenario.sections[section].kinds[c])

    def _open_decision(self, c: int, layout_kind: str | None = None) -> None:
        """A new decision of collective c; `layout_kind` for a section's first decisions."""
        self.decision_counts[c] += 1
        self.open[c] = dec.OpenDecision(
            collective=c,
            section=self.world.section,
            index=self.decision_counts[c],
            start_s=self.world.time,
            difficulty=dec.difficulty(self.world, c, self.params, layout_kind),
        )

    def _announce_commitments(self) -> None:
        """Announce each collective's commitment: the target most of its C agents hold."""
        w = self.world
        # (C, T) agents in C per target, from the kernel
        for c, t in _leading_targets(self._scratch.committed):
            if w.commit_announced[c] != t:
                w.commit_announced[c] = t
                self._event("commitment", int(c), t)

    def _begin_moves(self) -> None:
        """The first X agent of a collective begins its move: reserve the target, judge correctness."""
        w, p = self.world, self.params
        # (C, T) agents in X per target, from the kernel
        for c, t in _leading_targets(self._scratch.moving):
            if w.executing[c] >= 0 or self.open[c] is None:
                continue
            mine_all = w.collective == c
            if w.reserved_by[t] >= 0 and w.reserved_by[t] != c:
                w.send_home(
                    np.flatnonzero(mine_all & (w.target == t) & S.COMMITTED_OR_LATER[w.state])
                )
                continue
            decision = self.open[c]
            assert decision is not None  # checked above
            best = dec.best_available(w, int(c), p)
            decision.best_target = best
            decision.best_value = float(w.target_value[best]) if best >= 0 else float("nan")
            w.executing[c] = t
            w.reserved_by[t] = c
            rival = mine_all & S.COMMITTED_OR_LATER[w.state] & (w.target != t)
            w.send_home(np.flatnonzero(rival))
            rules.enforce_orders(w, p)  # other collectives drop the target at once
            self._event("move", int(c), t)

    def _end_decision(self, c: int) -> None:
        """The first D(i) quorum: the hub moves to target i and the next decision begins."""
        w = self.world
        t = int(w.executing[c])
        decision = self.open[c]
        assert decision is not None, "a collective moves only while deciding"
        chosen_distance = float(w.hub_distance[c, t])
        self._record(decision, t, chosen_distance, timed_out=False)
        w.hub[c] = w.target_pos[t]
        w.active[t] = False
        w.reserved_by[t] = -1
        rules.refresh_geometry(w, self.params)
        self._reset_collective(c)
        self._event("arrival", c, t)
        self._after_decision(c)

    def _time_out_decisions(self) -> None:
        limit = self.params.decision_timeout_s
        if limit is None or self.world.finished:
            return
        for c, decision in enumerate(self.open):
            if decision is not None and self.world.time - decision.start_s >= limit:
                self._record(decision, -1, None, timed_out=True)
                t = int(self.world.executing[c])
                if t >= 0:
                    self.world.reserved_by[t] = -1
                self._reset_collective(c)
                self._event("timeout", c, None)
                self._after_decision(c)
                if self.world.finished:
                    return

    def _reset_collective(self, c: int) -> None:
        w = self.world
        w.reset_agents_of(c)
        w.executing[c] = -1
        w.commit_announced[c] = -1
        w.abandon_order[c, :] = False
        for request in [r for r in self.requests if r.collective == c]:
            request.active = False
            self._remove_request(request)

    def _after_decision(self, c: int) -> None:
        w = self.world
        self.open[c] = None
        w.decisions_in_section += 1
        if w.decisions_in_section < self.params.decisions_per_section:
            self._open_decision(c)
            return
        self._event("section_end", None, None, section=w.section + 1)
        if w.section + 1 < len(self.scenario.sections):
            self._start_section(w.section + 1)
        else:
            w.finished = True
            self.open = [None] * w.n_collectives
            self._event("finished", None, None)

    def _record(
        self, decision: dec.OpenDecision, t: int, distance: float | None, timed_out: bool
    ) -> None:
        w = self.world
        chosen_value = None if t < 0 else float(w.target_value[t])
        best = decision.best_target
        self.decisions.append(
            dec.DecisionRecord(
                model=self.model,
                scenario_id=self.scenario.scenario_id,
                seed=self.scenario.seed,
                first_section=self.scenario.first_section,
                section=decision.section + 1,
                section_kind=self.scenario.sections[decision.section].kinds[decision.collective],
                collective=decision.collective,
                decision_index=decision.index,
                difficulty=decision.difficulty,
                start_s=decision.start_s,
                end_s=w.time,
                timed_out=timed_out,
                chosen_target=None if t < 0 else target_id(t),
                chosen_value=chosen_value,
                chosen_distance_m=distance,
                best_target=None if best < 0 else target_id(best),
                best_value=None if best < 0 else decision.best_value,
                correct=bool(
                    chosen_value is not None and best >= 0 and chosen_value >= decision.best_value
                ),
                n_investigate=decision.requests["investigate"],
                n_abandon=decision.requests["abandon"],
                n_decide=decision.requests["decide"],
                n_interventions=decision.requests["interventions"],
            )
        )

    # ---------------------------------------------------------- persistence
    def snapshot(self) -> bytes:
        """The whole state, including the generator's, as bytes (format: `snapshots`)."""
        state = {name: value for name, value in vars(self).items() if name not in DERIVED}
        state.update(
            scenario=self.scenario.to_dict(),
            params=self.params.stored_dict(),
            rng=self.rng.bit_generator.state,
        )
        return stamped(state)

    @classmethod
    def restore(cls, blob: bytes) -> Simulation:
        """A simulation that continues exactly where the snapshot was taken.

        Reads this version's format and the older ones `snapshots` converts;
        raises `snapshots.NewerSnapshotFormat` for a newer version's and
        SimulationError for anything else. Snapshots are pickles written by
        this class into our own database; never restore one from an untrusted
        source.
        """
        state = unstamped(blob)
        sim = cls.__new__(cls)
        sim.scenario = Scenario.from_dict(state.pop("scenario"))
        sim.params = Params.from_dict(state.pop("params"))
        sim.rng = np.random.default_rng()
        sim.rng.bit_generator.state = state.pop("rng")
        state.setdefault("status_changes", [])  # snapshots from before the status queue
        vars(sim).update(state)
        sim._prepare()
        return sim

    def state_digest(self) -> str:
        """A digest of the parameters, every state array, the clock, the generator and the requests."""
        h = hashlib.sha256()
        h.update(repr(sorted(self.params.stored_dict().items())).encode())
        for name, array in sorted(self.world.arrays().items()):
            h.update(name.encode())
            h.update(np.ascontiguousarray(array).tobytes())
        w = self.world
        h.update(
            repr((w.step_count, w.time, w.section, w.decisions_in_section, w.finished)).encode()
        )
        h.update(repr(self.rng.bit_generator.state).encode())
        h.update(repr([asdict(r.state()) for r in self.requests]).encode())
        h.update(repr([d.as_row() for d in self.decisions]).encode())
        return h.hexdigest()


def _leading_targets(counts: np.ndarray) -> list[tuple[int, int]]:
    """(collective, target) with the most agents (the first on ties), for each collective with any.

    Plain Python over the (C, T) counts: numpy's per-call cost dominates on arrays this small.
    """
    return [(c, row.index(max(row))) for c, row in enumerate(counts.tolist()) if any(row)]


def _as_int(value: object) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    return None
