"""The Simulation: one trial of collectives choosing sites.

`step()` runs the rules in a fixed order, each a vectorised function over all
agents: move, arrive, enforce standing orders, discover, rate transitions,
serve requests, exchange messages, begin moves, end decisions. One
`numpy.random.Generator` per trial (seeded from the scenario and the run
number) drives everything, and requests are applied between steps, so the
same scenario, run and timed request log reproduce a run bit for bit.
"""

from __future__ import annotations

import hashlib
import pickle

import numpy as np

from hcss.simulation import decisions as dec
from hcss.simulation import messaging, movement, rules
from hcss.simulation import states as S
from hcss.simulation.ids import target_id, target_index
from hcss.simulation.params import MODELS, ROMAN, Params
from hcss.simulation.requests import Request, RequestOutcome, recruit_for, refusal
from hcss.simulation.scenario import Scenario
from hcss.simulation.view import render_view
from hcss.simulation.world import World

SNAPSHOT_VERSION = 1


class SimulationError(ValueError):
    """The simulation cannot be built or restored as asked."""


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
        self.world = World.new(scenario, self.params)
        self.requests: list[Request] = []
        self.decisions: list[dec.DecisionRecord] = []
        self.open: list[dec.OpenDecision | None] = [None] * scenario.n_collectives
        self.decision_counts = [0] * scenario.n_collectives
        self.next_request_id = 1
        self.commands_applied = (
            0  # every command, accepted or refused: a replay's position in its log
        )
        self.events: list[dict] = []
        self._start_section(0)

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
        for _ in range(n):
            if self.world.finished:
                return
            self._step_once()

    def run_until_finished(self, max_steps: int | None = None) -> None:
        limit = max_steps if max_steps is not None else 10**9
        while not self.world.finished and self.world.step_count < limit:
            self._step_once()

    def _step_once(self) -> None:
        w, p, rng, model = self.world, self.params, self.rng, self.model
        at_target, at_hub = movement.move(w, p, rng)
        rules.reach_target(w, at_target, p, rng, model)
        visible = rules.reach_hub(w, at_hub)
        rules.enforce_orders(w)
        rules.discovery(w, p, rng, model)
        rules.rate_transitions(w, p, rng, model)
        for request in self.requests:
            recruit_for(w, request, rng)
        reached_done = messaging.exchange(w, p, rng, model)
        messaging.initiating_silence(w, p)
        in_hub = w.leg == S.AT_HUB
        w.reported_quadrant[in_hub] = S.QUADRANT_OF_STATE[w.state[in_hub]]
        w.step_count += 1
        w.time = w.step_count * p.dt_s
        for t in visible:
            self._event("discovery", None, int(t), f"Target {target_id(t)} discovered.")
        self._announce_commitments()
        self._begin_moves()
        section = w.section
        for c in np.flatnonzero(reached_done):
            # A decision that completes the section discards the others under way,
            # including any that reached their quorum in this same step.
            if w.finished or w.section != section:
                break
            if self.open[c] is not None and w.executing[c] >= 0:
                self._end_decision(int(c))
        self._time_out_decisions()

    # -------------------------------------------------------------- requests
    def apply(self, command: dict) -> RequestOutcome:
        """Apply one operator command: investigate, abandon, decide or cancel.

        Every command is counted, refused or not, so that a replay from a
        snapshot knows how much of the command log the snapshot contains.
        """
        self.commands_applied += 1
        kind = command.get("kind") if isinstance(command, dict) else None
        if kind == "cancel":
            return self._cancel(command.get("request_id"))
        if kind not in ("investigate", "abandon", "decide"):
            return RequestOutcome(False, None, f"Unknown request type {kind!r}.")
        return self._request(kind, command.get("collective"), command.get("target"))

    def investigate(self, collective: int, target: int) -> RequestOutcome:
        return self.apply({"kind": "investigate", "collective": collective, "target": target})

    def abandon(self, collective: int, target: int) -> RequestOutcome:
        return self.apply({"kind": "abandon", "collective": collective, "target": target})

    def decide(self, collective: int, target: int) -> RequestOutcome:
        return self.apply({"kind": "decide", "collective": collective, "target": target})

    def cancel_abandon(self, request_id: int) -> RequestOutcome:
        return self.apply({"kind": "cancel", "request_id": request_id})

    def _cancel(self, request_id: object) -> RequestOutcome:
        """Lift a standing abandon order; only an abandon can be cancelled."""
        for request in self.requests:
            if request.id == _as_int(request_id) and request.kind == "abandon" and request.active:
                request.active = False
                self.world.abandon_order[request.collective, request.target] = False
                self.requests.remove(request)
                self._count_request("cancel", request.collective, False)
                return RequestOutcome(True, request.id, "")
        return RequestOutcome(False, None, f"There is no active abandon assignment {request_id}.")

    def _request(self, kind: str, collective: object, target_id: object) -> RequestOutcome:
        c, t_id = _as_int(collective), _as_int(target_id)
        if c is None or t_id is None:
            return RequestOutcome(False, None, "A request needs a collective and a target.")
        w, p = self.world, self.params
        t = target_index(t_id)
        reason = refusal(w, p, kind, c, t)
        if reason:
            return RequestOutcome(False, None, reason)
        support = float(np.sum((w.collective == c) & w.favouring() & (w.target == t))) / p.n_agents
        needed = {"investigate": p.investigate_agents, "decide": p.decide_agents}.get(kind, 0)
        request = Request(self.next_request_id, kind, c, t, needed, support=support)
        self.next_request_id += 1
        self.requests.append(request)
        if kind == "abandon":
            w.abandon_order[c, t] = True
            rules.enforce_orders(w)
        recruit_for(w, request, self.rng)
        self._count_request(kind, c, kind == "abandon" and support >= p.intervention_support)
        return RequestOutcome(True, request.id, "")

    def _count_request(self, kind: str, collective: int, intervention: bool) -> None:
        decision = self.open[collective]
        if decision is not None:
            decision.requests[kind] += 1
            decision.requests["interventions"] += int(intervention)

    # ------------------------------------------------------------ observing
    def view(self) -> dict:
        """What the Collective Interface shows (spec §9), as JSON-able values."""
        return render_view(self)

    def drain_events(self) -> list[dict]:
        """System messages since the last call: discoveries, commitments, moves, arrivals."""
        events, self.events = self.events, []
        return events

    def best_target(self, collective: int) -> int | None:
        """The best available target id for a collective: the truth for level-2 probes."""
        best = dec.best_available(self.world, collective, self.params)
        return None if best < 0 else target_id(best)

    def _event(self, kind: str, collective: int | None, index: int | None, text: str) -> None:
        """Queue a system message; `index` is the target's array index, stored as its public id."""
        target = None if index is None else target_id(index)
        self.events.append(
            {
                "time": self.world.time,
                "kind": kind,
                "collective": collective,
                "target": target,
                "text": text,
            }
        )

    # ------------------------------------------------------------ decisions
    def _start_section(self, section: int) -> None:
        w = self.world
        w.section, w.decisions_in_section = section, 0
        w.active[:] = w.target_section == section
        w.reserved_by[:] = -1
        w.hub[:] = w.start_hub
        w.refresh_hub_distance()
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
        movement.scatter_in_hub(w, everyone, self.params, self.rng)
        self.requests.clear()
        for c in range(w.n_collectives):
            self._open_decision(c)

    def _open_decision(self, c: int) -> None:
        self.decision_counts[c] += 1
        self.open[c] = dec.OpenDecision(
            collective=c,
            section=self.world.section,
            index=self.decision_counts[c],
            start_s=self.world.time,
            difficulty=dec.difficulty(self.world, c, self.params),
        )

    def _announce_commitments(self) -> None:
        w = self.world
        committed = np.flatnonzero(w.state == S.C)
        if committed.size == 0:
            return
        for c in np.unique(w.collective[committed]):
            targets = w.target[committed[w.collective[committed] == c]]
            t = int(np.bincount(targets).argmax())
            if w.commit_announced[c] != t:
                w.commit_announced[c] = t
                self._event(
                    "commitment",
                    int(c),
                    t,
                    f"Collective {ROMAN[c]} committed to target {target_id(t)}.",
                )

    def _begin_moves(self) -> None:
        """The first X agent of a collective begins its move: reserve the target, judge correctness."""
        w, p = self.world, self.params
        moving = np.flatnonzero(w.state == S.X)
        if moving.size == 0:
            return
        for c in np.unique(w.collective[moving]):
            if w.executing[c] >= 0 or self.open[c] is None:
                continue
            mine = moving[w.collective[moving] == c]
            t = int(np.bincount(w.target[mine]).argmax())
            mine_all = w.collective == c
            if w.reserved_by[t] >= 0 and w.reserved_by[t] != c:
                self._send_home(
                    np.flatnonzero(mine_all & (w.target == t) & S.COMMITTED_OR_LATER[w.state])
                )
                continue
            decision = self.open[c]
            best = dec.best_available(w, int(c), p)
            decision.best_target = best
            decision.best_value = float(w.target_value[best]) if best >= 0 else float("nan")
            w.executing[c] = t
            w.reserved_by[t] = c
            rival = mine_all & S.COMMITTED_OR_LATER[w.state] & (w.target != t)
            self._send_home(np.flatnonzero(rival))
            rules.enforce_orders(w)  # other collectives drop the target at once
            self._event(
                "move", int(c), t, f"Collective {ROMAN[c]} is moving to target {target_id(t)}."
            )

    def _send_home(self, agents: np.ndarray) -> None:
        """Reset agents to uncommitted; those away from the hub fly back to it."""
        w = self.world
        away = agents[w.leg[agents] != S.AT_HUB]
        w.set_state(agents, S.U_I)
        w.set_state(away, S.U_L)
        w.leg[away] = S.TO_HUB
        w.arrival_state[away] = S.U_I

    def _end_decision(self, c: int) -> None:
        """The first D(i) quorum: the hub moves to target i and the next decision begins."""
        w = self.world
        t = int(w.executing[c])
        decision = self.open[c]
        chosen_distance = float(w.hub_distance[c, t])
        self._record(decision, t, chosen_distance, timed_out=False)
        w.hub[c] = w.target_pos[t]
        w.active[t] = False
        w.reserved_by[t] = -1
        w.refresh_hub_distance()
        self._reset_collective(c)
        self._event("arrival", c, t, f"Collective {ROMAN[c]} arrived at target {target_id(t)}.")
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
                self._event("timeout", c, None, f"Collective {ROMAN[c]} timed out.")
                self._after_decision(c)
                if self.world.finished:
                    return

    def _reset_collective(self, c: int) -> None:
        w = self.world
        mine = np.flatnonzero(w.collective == c)
        at_new_site = mine[(w.state[mine] == S.D) & (w.leg[mine] == S.AT_HUB)]
        w.set_state(at_new_site, S.U_I)
        self._send_home(np.setdiff1d(mine, at_new_site, assume_unique=True))
        w.executing[c] = -1
        w.commit_announced[c] = -1
        w.abandon_order[c, :] = False
        for request in [r for r in self.requests if r.collective == c]:
            request.active = False
            self.requests.remove(request)

    def _after_decision(self, c: int) -> None:
        w = self.world
        self.open[c] = None
        w.decisions_in_section += 1
        if w.decisions_in_section < self.params.decisions_per_section:
            self._open_decision(c)
            return
        self._event("section_end", None, None, f"Section {w.section + 1} complete.")
        if w.section + 1 < len(self.scenario.sections):
            self._start_section(w.section + 1)
        else:
            w.finished = True
            self.open = [None] * w.n_collectives
            self._event("finished", None, None, "All decisions complete.")

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
        """The whole state, including the generator's, as bytes."""
        state = {
            name: value
            for name, value in vars(self).items()
            if name not in ("rng", "scenario", "params")
        }
        state.update(
            version=SNAPSHOT_VERSION,
            scenario=self.scenario.to_dict(),
            params=self.params.to_dict(),
            rng=self.rng.bit_generator.state,
        )
        return pickle.dumps(state, protocol=pickle.HIGHEST_PROTOCOL)

    @classmethod
    def restore(cls, blob: bytes) -> Simulation:
        """A simulation that continues exactly where the snapshot was taken.

        Snapshots are pickles written by this class into our own database;
        never restore one from an untrusted source.
        """
        try:
            state = pickle.loads(blob)
        except Exception as error:  # noqa: BLE001 - any unpickling failure means "not a snapshot"
            raise SimulationError(f"not a simulation snapshot: {error}") from error
        if not isinstance(state, dict) or state.get("version") != SNAPSHOT_VERSION:
            raise SimulationError("not a simulation snapshot of this version")
        sim = cls.__new__(cls)
        sim.scenario = Scenario.from_dict(state.pop("scenario"))
        sim.params = Params.from_dict(state.pop("params"))
        sim.rng = np.random.default_rng()
        sim.rng.bit_generator.state = state.pop("rng")
        state.pop("version")
        vars(sim).update(state)
        return sim

    def state_digest(self) -> str:
        """A digest of the parameters, every state array, the clock, the generator and the requests."""
        h = hashlib.sha256()
        h.update(repr(sorted(self.params.to_dict().items())).encode())
        for name, array in sorted(self.world.arrays().items()):
            h.update(name.encode())
            h.update(np.ascontiguousarray(array).tobytes())
        w = self.world
        h.update(
            repr((w.step_count, w.time, w.section, w.decisions_in_section, w.finished)).encode()
        )
        h.update(repr(self.rng.bit_generator.state).encode())
        h.update(repr([r.to_view() for r in self.requests]).encode())
        h.update(repr([d.as_row() for d in self.decisions]).encode())
        return h.hexdigest()


def _as_int(value: object) -> int | None:
    if isinstance(value, bool):
        return None
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, str) and value.strip().lstrip("-").isdigit():
        return int(value)
    return None
