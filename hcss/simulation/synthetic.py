"""A synthetic operator: a participant's behaviour with the parameters that matter, drawn per person.

The scripted operators of `operators.py` are fixed by hand; this one has a
`Traits` value per synthetic participant, drawn from a `Population` (each
trait a distribution over people), so the spread between people and between
decisions that the study's human tables show (SPEC-simulation.md §11) can be
fitted (`hcss simulate calibrate --to study-teams`).

It acts only on what the interface shows: each `look` takes a `Display` (in
process `Simulation.display()`, over HTTP `Display.from_json` of a stream
frame) and returns a `Glance` (its requests and observation clicks), and
each probe answer comes from what it remembers of the displays it looked at.
Nothing here can reach the simulation's truth, so a truth-only change cannot
change its actions (tests/simulation/test_synthetic.py plants one).

Its randomness is two streams of its own, seeded from the participant: one for
looks, one for probes. A look draws the same numbers whatever the probes did,
so the in-process path (`hcss.experiments.synthetic_trials`) and the HTTP bot
(`hcss.platform.bots.synthetic`) give the same requests for the same seed and
pace, however their probes interleave.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np

from hcss.simulation.messages import collective_names
from hcss.simulation.requests import IN_PROGRESS, OperatorCommand, RequestState
from hcss.simulation.view import Display

DECIDE_FLOOR = 0.30  # the simulation refuses a decide below this support (spec §8)
#: How much more a committed agent says "about to decide" than a supporter: a person's level-3
#: rule (measured on the default preset, M1: 3 x committed + support names the next decision
#: 60% of the time, committed + support 58%, support alone 45%).
COMMITTED_WEIGHT = 3.0
#: Support beyond what a person's own investigates sent (10 agents each, as the instructions
#: say) that only a collective's own recruitment gives: what tells a person the collectives
#: move by themselves. Measured on the default preset with no
#: requests: M3's never passed 8% in 10 min (4 scenarios), M1's and M2's passed 15% within
#: 30-110 s.
SELF_MOVING_SUPPORT = 0.15
ON_THE_MOVE = 10.0  # closeness of a collective on the move: it ends its decision when it lands
INVESTIGATE_AGENTS = (
    10  # agents an investigate sends (spec §8), as the interface's instructions say
)


@dataclass(frozen=True)
class Traits:
    """One synthetic participant. Times in seconds, supports as fractions of the collective.

    - `glance_interval_s`: how often attention turns to a collective (one
      collective at a time, round robin), so a collective is attended every
      4 glances unless attention stays.
    - `stay_prob`: chance that attention stays, for the next glance, on the
      collective it has just clicked a request on or whose investigates it is
      waiting on (a person keeps working on a collective that needs them
      rather than moving on).
    - `reaction_time_s`: from a look to its clicks landing (reading the map,
      filling the request form, Commit).
    - `value_noise`: sd of a person's reading of a target's value from its
      green opacity; which target "looks best" is the noisy reading's.
    - `value_resolution`: how far apart two readings must be for a person to
      tell one target's green from another's; of targets that look equally
      good the nearer to the hub looks best (for its requests and its level-2
      answers alike).
    - `investigate_prob`: chance, when attending a collective seen moving by
      itself whose best-looking target is below `decide_support`, to nudge it:
      one investigate of that target, at any time (repeatable, as on the
      interface, even while one is in progress).
    - `stalled_investigate_prob`: chance, when the collective looks stuck, to
      push it: a burst of investigates (`investigate_burst`), once the person
      has watched the target for `survey_s`. It looks stuck when the leading
      target's support has not grown for `stall_window_s`, and at every look
      until the person has seen some collective move by itself in this trial
      (a target's support `SELF_MOVING_SUPPORT` above what the person's own
      investigates of it sent): a person supervising collectives that move
      only by their requests, as M3's, pushes them; one who has seen them grow
      on their own, as M1's and M2's, nudges and waits.
    - `stall_window_s`: how long a person waits for a leading target's support
      to grow before judging the collective stuck.
    - `survey_s`: how long a person watches a target before pushing it: from
      the start of the collective's decision (when its hub is seen to move) or
      from when the target was first drawn on the map, whichever is later. A
      far target found late (the best one of a difficult decision) is pushed
      later than a near one found early.
    - `investigate_burst`: how many investigates one look sends at most (the
      person presses Commit again on the same form): as many as it takes the
      target to reach `decide_support` at 10 agents each, up to this many. A
      collective that moves only by requests loses supporters as they
      reassess, so support reaches 30% only from investigates sent together.
    - `decide_support`: the support at which it considers deciding; never below
      30% (below that the interface refuses a decide).
    - `decide_prob`: chance, when support allows and the collective looks stuck
      (as above: stalled, or no collective seen moving by itself), to decide.
    - `hasten_prob`: the same chance when the collective looks to be moving by
      itself: deciding for it rather than letting it reach its own quorum.
    - `abandon_support`, `abandon_gap`, `abandon_prob`: it abandons a target
      its collective supports at `abandon_support` or more whose value looks
      `abandon_gap` or more below the best-looking one, with this chance per
      look (an intervention when support is 10% or more).
    - `redirect_prob`: chance per look of taking back agents the person sent
      (by investigates in the collective's current decision) to a target that
      no longer looks best: it abandons that target (an intervention when its
      support is 10% or more). A person who pushed the best target it had seen
      and then sees a better one redirects the collective; nothing else
      abandons in M3, where all support is the person's own.
    - `slip_prob`: chance that a request is erroneous (a decide under 30%, an
      abandon of an unsupported target): the interface refuses it.
    - `observe_collective_prob`: chance per look of a right-click on the
      attended hub (its U/F/C/X detail).
    - `observe_target_prob`: chance, on a look that sends requests, of a
      right-click on the first request's target first (its support per
      collective, checked before committing): a person looks a target up when
      about to act on it, so target clicks follow requests (§11: M3's
      operators, who request most, clicked targets on twice as many
      decisions as M1's and M2's).
    - `observe_change_prob`: the chance of that hub right-click instead, on a
      look at a deliberating collective whose best-looking target is not the
      one it was at the person's last look at it in this decision (a better
      target has come in sight): a person checks how far the collective has
      gone for the old one. Difficult decisions (the best target farthest,
      found late) have such a look; easy ones seldom do (§11: hub clicks on
      94% of M1's difficult decisions and 66% of its easy ones).
    - `perception_lapse`, `comprehension_lapse`, `projection_lapse`: chance of
      answering a probe of that level at random (inattention, a misread)
      rather than from what it remembers: a person's accuracy by SA level.
    - `probe_ready_s`, `probe_answer_s`: from a probe showing to "ready", and
      from the question showing to the answer; both inside the 30 s window.
    - `push_margin`: how far past `decide_support` a push aims (support as a
      fraction). A push of exactly what the threshold needs peaks at it and
      sheds below it before the person looks again (an M3 collective loses
      the supporters an investigate sends as they reassess), so a second push
      follows; a person who has seen that sends one more.
    """

    glance_interval_s: float = 2.5
    stay_prob: float = 0.3
    reaction_time_s: float = 3.0
    value_noise: float = 0.02
    value_resolution: float = 0.05
    investigate_prob: float = 0.08
    stalled_investigate_prob: float = 0.9
    stall_window_s: float = 30.0
    survey_s: float = 0.0
    investigate_burst: float = 1.0
    decide_support: float = 0.4
    decide_prob: float = 0.3
    hasten_prob: float = 0.3
    abandon_support: float = 0.1
    abandon_gap: float = 0.1
    abandon_prob: float = 0.3
    redirect_prob: float = 0.0
    slip_prob: float = 0.01
    observe_collective_prob: float = 0.05
    observe_target_prob: float = 0.01
    perception_lapse: float = 0.1
    comprehension_lapse: float = 0.1
    projection_lapse: float = 0.1
    probe_ready_s: float = 2.0
    probe_answer_s: float = 4.0
    # each added last, so adding it left every other trait's draw for a participant as it was
    observe_change_prob: float = 0.0
    push_margin: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            _finite(f.name, getattr(self, f.name))
        if self.glance_interval_s <= 0 or self.reaction_time_s < 0:
            raise ValueError("a glance interval must be positive and a reaction time not negative")
        if self.decide_support < DECIDE_FLOOR:
            raise ValueError(f"decide_support below {DECIDE_FLOOR} would only be refused")
        if not 0.0 <= self.push_margin <= 1.0:
            raise ValueError(f"push_margin is a share of the collective, not {self.push_margin}")
        for name in TRAIT_PROBABILITIES:
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} is a probability, not {getattr(self, name)}")

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


def _finite(name: str, value: object) -> None:
    """A trait (or the spread) is a finite number: NaN would make a person who never looks
    (no glance time can be counted), and JSON's true would pass as a probability of 1."""
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, not {value!r}")


TRAIT_PROBABILITIES = (
    "stay_prob",
    "investigate_prob",
    "stalled_investigate_prob",
    "decide_prob",
    "hasten_prob",
    "abandon_prob",
    "redirect_prob",
    "slip_prob",
    "observe_collective_prob",
    "observe_target_prob",
    "observe_change_prob",
    "perception_lapse",
    "comprehension_lapse",
    "projection_lapse",
)
#: Traits bounded to [0, 1]: drawn on the logit scale. The others are positive: log scale.
_BOUNDED = frozenset((*TRAIT_PROBABILITIES, "abandon_support", "value_noise", "value_resolution"))


@dataclass(frozen=True)
class Population:
    """How synthetic participants differ: each trait's median person and spread.

    A participant's trait is the median moved by `spread` standard normal
    deviates on the trait's natural scale (logit for probabilities and
    supports, log for times and gaps), so every draw is valid. One `spread`
    for all traits keeps the fit small: people who glance often also tend to
    act often is not assumed, each trait draws its own deviate.
    `decide_support` is drawn above the 30% floor (its excess over 0.30 on
    the log scale). A probability whose median is exactly 0 or 1 (a person
    who never, or always, does it) is everyone's.
    """

    median: Traits = Traits()
    spread: float = 0.3

    def __post_init__(self) -> None:
        _finite("spread", self.spread)
        if self.spread < 0:
            raise ValueError(f"spread is a standard deviation, not {self.spread}")

    def draw(self, rng: np.random.Generator) -> Traits:
        values: dict[str, float] = {}
        for f in fields(Traits):
            centre = float(getattr(self.median, f.name))
            z = float(rng.standard_normal()) * self.spread
            if f.name == "decide_support":
                excess = max(centre - DECIDE_FLOOR, 1e-3)
                values[f.name] = min(0.95, DECIDE_FLOOR + excess * math.exp(z))
            elif f.name in _BOUNDED and centre in (0.0, 1.0):
                values[f.name] = centre  # never, or always: so for everyone
            elif f.name in _BOUNDED:
                p = min(max(centre, 1e-4), 1 - 1e-4)
                values[f.name] = 1.0 / (1.0 + math.exp(-(math.log(p / (1 - p)) + z)))
            else:
                values[f.name] = centre * math.exp(z)
        return Traits(**values)

    def participant(self, seed: int) -> Traits:
        """The traits of the synthetic participant with this seed."""
        return self.draw(np.random.default_rng([seed, 0x7A17]))

    def to_dict(self) -> dict[str, Any]:
        return {"median": self.median.to_dict(), "spread": self.spread}

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> Population:
        return cls(Traits(**values["median"]), values["spread"])

    def with_median(self, **changes: float) -> Population:
        return replace(self, median=replace(self.median, **changes))


@dataclass(frozen=True)
class ObservationClick:
    """An observation click (not part of a request): a hub or a target, left or right button."""

    kind: str  # "collective" or "target"
    collective: int | None = None
    target: int | None = None
    button: str = "right"

    def to_json(self) -> dict[str, Any]:
        """The body the platform's observation endpoint takes."""
        body: dict[str, Any] = {"kind": self.kind, "button": self.button}
        if self.kind == "collective":
            body["collective"] = self.collective
        else:
            body["target"] = self.target
        return body


@dataclass(frozen=True)
class Glance:
    """What one look produced: the collective attended and the clicks to land after the reaction time."""

    collective: int | None
    commands: tuple[OperatorCommand, ...] = ()
    observations: tuple[ObservationClick, ...] = ()


@dataclass
class _Memory:
    """What the operator last saw of one collective (the whole map is seen at each look)."""

    time: float
    support: dict[int, float]  # target id -> this collective's support
    closeness: float  # how near a decision it looked: committed, then supported; moving least
    hub: tuple[float, float]


class SyntheticOperator:
    """One synthetic participant supervising one trial, from what the interface shows."""

    def __init__(self, traits: Traits, seed: int) -> None:
        self.traits = traits
        root = np.random.SeedSequence([seed, 0x0B5])
        looks, probes = root.spawn(2)
        self.rng = np.random.default_rng(looks)
        self.probe_rng = np.random.default_rng(probes)
        self.focus = 0
        self.memory: dict[int, _Memory] = {}
        self.values: dict[int, float] = {}  # target id -> its value as last read
        self.places: dict[int, tuple[float, float]] = {}  # target id -> where it is drawn
        # collective -> (leading target, its support, since when it has not grown)
        self.growth: dict[int, tuple[int, float, float]] = {}
        self.pushed: Counter[tuple[int, int]] = Counter()  # (collective, target) -> investigates
        self.sent: dict[tuple[int, int], float] = {}  # (collective, target) -> its burst lands
        self.started: dict[int, float] = {}  # collective -> when its hub was seen to move
        self.appeared: dict[int, float] = {}  # target id -> when it was first seen drawn
        # request kind -> collective -> when the person first sent it one in its decision
        self.worked: dict[str, dict[int, float]] = {}
        # collective -> since when the person has watched its best-looking target
        self.watching: dict[int, float] = {}
        self.seen_self_moving = False  # has it seen a collective gain support by itself?
        # collective -> (its decision's start, the target that looked best at the last look)
        self.best_seen: dict[int, tuple[float, int]] = {}

    def glance_times(self, until_s: float) -> list[float]:
        """When it looks, from the trial's start: every glance interval."""
        step = self.traits.glance_interval_s
        return [k * step for k in range(1, int(until_s / step) + 1)]

    def look(self, display: Display) -> Glance:
        """See the map, attend the next collective and decide what to click on it."""
        t, d = self.traits, display
        if not d.n_collectives or d.finished:
            return Glance(None)
        c = self.focus % d.n_collectives
        u = self.rng.random(9)  # a fixed number of draws per look: paths stay in step
        glance = self._attend(d, c, u)
        for command in glance.commands:
            if command.kind in ("decide", "investigate"):
                first = self.worked.setdefault(command.kind, {})
                if c not in self._this_decision(first):
                    first[c] = d.time  # the first of this kind in c's current decision
        working = glance.commands or self._awaiting(d, c)
        if not (working and u[7] < t.stay_prob):
            self.focus += 1  # attention moves on, unless it stays where it is working
        return glance

    def _awaiting(self, d: Display, c: int) -> bool:
        """Whether the person is waiting on collective c's investigates: sent and not yet
        landed, or shown in progress (a person watches a push they have just made)."""
        if any(c == k[0] and d.time < landed for k, landed in self.sent.items()):
            return True
        return any(True for _ in _investigating(d, c))

    def _attend(self, d: Display, c: int, u: np.ndarray) -> Glance:
        """One look at collective c: its observation clicks and requests."""
        t = self.traits
        noise = self.rng.standard_normal(len(d.target_ids)) * t.value_noise
        read = np.asarray(d.value, dtype=float) + noise
        ids = [int(x) for x in d.target_ids.tolist()]
        self._remember(d, ids, read)
        shown = np.flatnonzero(d.in_range[c] & d.drawn)
        deliberating = not d.executing[c] and shown.size > 0
        best = _best_looking(d, c, shown, read, t.value_resolution) if deliberating else -1
        hub_click = t.observe_collective_prob
        if deliberating and self._best_changed(c, ids[best]):
            hub_click = max(hub_click, t.observe_change_prob)
        observations: list[ObservationClick] = []
        if u[0] < hub_click:
            observations.append(ObservationClick("collective", collective=c))
        if not deliberating:
            return Glance(c, (), tuple(observations))
        watched_since = max(self.started.get(c, 0.0), self.appeared[ids[best]])
        self.watching[c] = watched_since
        commands: list[OperatorCommand] = []
        abandoned = {r.target for r in d.requests if r.collective == c and r.kind == "abandon"}
        if u[2] < t.abandon_prob:
            weak = [
                v
                for v in shown.tolist()
                if v != best
                and d.support[c, v] >= t.abandon_support
                and read[v] <= read[best] - t.abandon_gap
                and ids[v] not in abandoned
            ]
            if weak:
                worst = max(weak, key=lambda v: float(d.support[c, v]))
                commands.append(OperatorCommand("abandon", c, ids[worst]))
                abandoned.add(ids[worst])
        if u[8] < t.redirect_prob:
            commands.extend(
                OperatorCommand("abandon", c, ids[v])
                for v in self._misdirected(d, c, shown, best, abandoned)
            )
        support = float(d.support[c, best])
        stuck = self._stalled(c, ids[best], support, d.time) or not self.seen_self_moving
        if support >= t.decide_support:
            if u[3] < (t.decide_prob if stuck else t.hasten_prob):
                commands.append(OperatorCommand("decide", c, ids[best]))
        elif not stuck:
            if u[4] < t.investigate_prob:  # a nudge: one investigate, at any time
                self._investigate(d, c, ids[best], 1, commands)
        elif d.time - watched_since >= t.survey_s and u[4] < t.stalled_investigate_prob:
            # a push, once the target has been watched: what the threshold needs
            self._investigate(d, c, ids[best], self._burst(d, c, ids[best], support), commands)
        if commands and u[1] < t.observe_target_prob:  # its support checked before the request
            observations.append(ObservationClick("target", target=commands[0].target))
        if commands and u[5] < t.slip_prob:
            slip = _slip(d, c, shown, u[6])
            if slip is not None:
                commands.append(slip)
        return Glance(c, tuple(commands), tuple(observations))

    def _best_changed(self, c: int, target: int) -> bool:
        """Whether collective c's best-looking target differs from the one at the person's
        last look at it in its current decision (a first look has nothing to differ from)."""
        start = self.started.get(c, 0.0)
        before = self.best_seen.get(c)
        self.best_seen[c] = (start, target)
        return before is not None and before[0] == start and before[1] != target

    def _misdirected(
        self, d: Display, c: int, shown: np.ndarray, best: int, abandoned: set[int]
    ) -> list[int]:
        """Targets the person sent collective c's agents to in its current decision that no
        longer look best and still hold supporters (none already being abandoned)."""
        ids = d.target_ids
        since = self.started.get(c, 0.0)
        return [
            v
            for v in shown.tolist()
            if v != best
            and self.sent.get((c, int(ids[v])), -math.inf) >= since
            and d.support[c, v] > 0
            and int(ids[v]) not in abandoned
        ]

    def _investigate(
        self, d: Display, c: int, target: int, n: int, commands: list[OperatorCommand]
    ) -> None:
        """Send n investigates of the target, remembering them (how far it was pushed, when
        they land)."""
        if n:
            commands.extend([OperatorCommand("investigate", c, target)] * n)
            self.pushed[(c, target)] += n
            self.sent[(c, target)] = d.time + self.traits.reaction_time_s

    def _burst(self, d: Display, c: int, target: int, support: float) -> int:
        """How many investigates to send now: as many as bring the target `push_margin` past
        `decide_support` with the agents still to come from investigates in progress (the
        list shows their acknowledgements), up to `investigate_burst`, and at least one (a
        person below the threshold who chose to push, pushes); none while its own last ones
        have not landed."""
        if d.time < self.sent.get((c, target), -math.inf):
            return 0
        coming = sum(
            max(0, INVESTIGATE_AGENTS - r.acknowledged)
            for r in _investigating(d, c)
            if r.target == target
        )
        aim = self.traits.decide_support + self.traits.push_margin
        short = ((aim - support) * d.n_agents - coming) / INVESTIGATE_AGENTS
        return max(1, min(round(self.traits.investigate_burst), math.ceil(short)))

    def _stalled(self, c: int, target: int, support: float, now: float) -> bool:
        """Whether the leading target's support has not grown for `stall_window_s`."""
        before = self.growth.get(c)
        if before is None or before[0] != target or support > before[1]:
            self.growth[c] = (target, support, now)
            return False
        return now - before[2] >= self.traits.stall_window_s

    def _moving_by_itself(self, d: Display, ids: list[int]) -> bool:
        """Whether a deliberating collective (none of its agents committed) supports a target
        `SELF_MOVING_SUPPORT` beyond what the person's investigates of it sent."""
        sent = INVESTIGATE_AGENTS / max(d.n_agents, 1)
        for c in np.flatnonzero(~d.executing & (d.state_counts[:, 2] + d.state_counts[:, 3] == 0)):
            for v, target in enumerate(ids):
                pushed = self.pushed.get((int(c), target), 0) * sent
                if float(d.support[c, v]) >= SELF_MOVING_SUPPORT + pushed:
                    return True
        return False

    def _remember(self, d: Display, ids: list[int], read: np.ndarray) -> None:
        """What a look takes in of the whole map: values read, supports, who is near a decision.

        A value is remembered as last read (the map's reported values firm up as reports
        come in, so the latest reading is the person's best). A collective that is moving
        has just made its decision: it is the farthest from the next one.
        """
        for v, target in enumerate(ids):
            self.values[target] = float(read[v])
            self.places[target] = (float(d.position[v, 0]), float(d.position[v, 1]))
            if d.drawn[v]:
                self.appeared.setdefault(target, d.time)
        if not self.seen_self_moving:
            self.seen_self_moving = self._moving_by_itself(d, ids)
        n = max(d.n_agents, 1)
        for c in range(d.n_collectives):
            support = {ids[v]: float(d.support[c, v]) for v in range(len(ids))}
            committed = float(d.state_counts[c, 2] + d.state_counts[c, 3]) / n
            closeness = (
                ON_THE_MOVE + float(d.state_counts[c, 3]) / n
                if d.executing[c]
                else COMMITTED_WEIGHT * committed + max(support.values(), default=0.0)
            )
            hub = (float(d.hub[c, 0]), float(d.hub[c, 1]))
            if c in self.memory and self.memory[c].hub != hub:
                self.started[c] = d.time  # it has landed: its next decision has begun
            self.memory[c] = _Memory(d.time, support, closeness, hub)

    def _next_to_bring(self, closest: int) -> int:
        """With none on the move, for a person who has seen no collective move by itself
        (only its requests decide, as in M3): the collective it is bringing to a decision,
        the first it decided for in that collective's current decision, else the first it
        pushed (its push landed first), else the one it will push first (whose best-looking
        target it has watched longest in its current decision). For one who has seen them
        move by themselves, the closest it saw. Measured on the fitted population (12
        participants' M3 and M1 trials): the decided-for collective named M3's next
        decision 4 times of 4 where the last pushed named it 2 of 4; in M1 the closest
        named it more often than the person's own pushes."""
        if self.seen_self_moving:
            return closest
        decided, pushed = self.worked.get("decide", {}), self.worked.get("investigate", {})
        for times in (decided, pushed, self.watching):
            current = self._this_decision(times)
            if current:
                return min(current, key=lambda k: current[k])
        return closest

    def _this_decision(self, times: dict[int, float]) -> dict[int, float]:
        """Of times by collective, those since that collective's current decision began (a
        collective that has landed starts afresh: what was sent or watched before is over)."""
        return {c: at for c, at in times.items() if at >= self.started.get(c, 0.0)}

    def answer(self, level: int, question: str, choices: Sequence[str]) -> str:
        """A probe's answer from memory; at random on a lapse or with nothing remembered.

        Level 1 (which collective is investigating target t): the collective it
        last saw supporting t most. Level 2 (the best target for collective
        c): the choice whose value it last read highest. Level 3 (which
        collective decides next): one it last saw on the move (its decision ends
        when it lands); else, for a person who has seen no collective move by
        itself, the one it is bringing to a decision or will push first
        (`_next_to_bring`); else the one it last saw most committed and
        supported. Each level has its own lapse: the person's accuracy at that
        level.
        """
        if not choices:
            return ""
        u, pick = self.probe_rng.random(), int(self.probe_rng.integers(len(choices)))
        guess = choices[pick]
        lapse = (
            self.traits.perception_lapse,
            self.traits.comprehension_lapse,
            self.traits.projection_lapse,
        )[min(max(level, 1), 3) - 1]
        if u < lapse or not self.memory:
            return guess
        names = collective_names()
        if level == 1:
            target = _number_in(question)
            seen = {c: m.support.get(target, -1.0) for c, m in self.memory.items()}
            c = max(seen, key=lambda k: seen[k])
            return names[c] if seen[c] > 0 and names[c] in choices else guess
        if level == 2:
            known = [int(x) for x in choices if x.isdecimal() and int(x) in self.values]
            subject = _collective_in(question, names)
            if not known or subject is None or subject not in self.memory:
                return guess
            top = max(self.values[x] for x in known)
            alike = [x for x in known if self.values[x] >= top - self.traits.value_resolution]
            hub = self.memory[subject].hub
            return str(min(alike, key=lambda x: math.dist(self.places[x], hub)))
        c = max(self.memory, key=lambda k: self.memory[k].closeness)
        if self.memory[c].closeness < ON_THE_MOVE:
            c = self._next_to_bring(c)
        return names[c] if names[c] in choices else guess


def _best_looking(
    d: Display, c: int, shown: np.ndarray, read: np.ndarray, resolution: float
) -> int:
    """The shown target that looks best to collective c: the highest reading, and of the
    readings a person cannot tell apart from it, the target nearest the hub."""
    top = float(read[shown].max())
    alike = shown[read[shown] >= top - resolution]
    distance = np.hypot(*(d.position[alike] - d.hub[c]).T)
    return int(alike[int(np.argmin(distance))])


def _investigating(d: Display, c: int) -> Iterator[RequestState]:
    """Collective c's investigates the list shows in progress (agents still to acknowledge)."""
    return (
        r
        for r in d.requests
        if r.collective == c and r.kind == "investigate" and r.status == IN_PROGRESS
    )


def _slip(d: Display, c: int, shown: np.ndarray, u: float) -> OperatorCommand | None:
    """An erroneous request the interface refuses: a decide under 30%, or an abandon of a
    target with no supporters (the form filled for the wrong target)."""
    weak = [v for v in shown.tolist() if d.support[c, v] < DECIDE_FLOOR]
    if not weak:
        return None
    v = weak[int(u * len(weak))]
    kind = "decide" if d.support[c, v] * d.n_agents >= 2 else "abandon"
    return OperatorCommand(kind, c, int(d.target_ids[v]))


def _number_in(text: str) -> int:
    digits = "".join(ch if ch.isdigit() else " " for ch in text).split()
    return int(digits[-1]) if digits else -1


def _collective_in(question: str, names: Sequence[str]) -> int | None:
    words = question.rstrip("?").split()
    for c, name in enumerate(names):
        if name in words:
            return c
    return None
