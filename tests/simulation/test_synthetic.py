"""The synthetic operator acts on what the interface shows, never on the simulation's truth."""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from hcss.experiments.synthetic_trials import run_trial
from hcss.simulation import Scenario, Simulation
from hcss.simulation.presets import preset_params
from hcss.simulation.synthetic import Population, SyntheticOperator, Traits
from hcss.simulation.view import Display, Truth

PARAMS = preset_params()
BUSY = Traits(
    glance_interval_s=2.0,
    investigate_prob=0.9,
    stalled_investigate_prob=1.0,
    decide_prob=0.9,
    abandon_prob=0.9,
    abandon_support=0.05,
    abandon_gap=0.05,
    slip_prob=0.2,
    observe_collective_prob=0.5,
    observe_target_prob=0.5,
)


def _scenario(seed: int = 11) -> Scenario:
    return Scenario.generate(seed, first_section="difficult", params=PARAMS)


def test_a_planted_truth_changes_no_look() -> None:
    """Two simulations alike in all the display shows, with the true values planted
    otherwise in one: the same operator clicks the same, look after look."""
    sim = Simulation(_scenario(), "M1", PARAMS)
    sim.step(240)
    planted = Simulation.restore(sim.snapshot())
    w = planted.world
    w.target_value[:] = w.target_value[::-1].copy()  # the truth only: no agent has moved
    assert not np.array_equal(planted.truth().values, sim.truth().values)
    assert planted.truth().best_target.tolist() != sim.truth().best_target.tolist()
    a, b = SyntheticOperator(BUSY, 3), SyntheticOperator(BUSY, 3)
    clicks = 0
    for _ in range(12):
        first, second = a.look(sim.display()), b.look(planted.display())
        assert first == second
        clicks += len(first.commands) + len(first.observations)
    assert clicks > 0  # it did act: the equality is about actions, not about silence


def test_a_planted_truth_changes_no_request_in_a_whole_trial(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A whole operated trial, then again with `Simulation.truth` planted (reversed values,
    no best target): the probes' truths change, the requests and decisions do not."""
    scenario = _scenario(12)
    _, honest = run_trial(scenario, "M1", PARAMS, SyntheticOperator(BUSY, 5), "p", "t", 600.0)

    def planted(self: Simulation) -> Truth:
        values = np.array(self.world.target_value[::-1], dtype=float)
        return Truth(values, np.zeros(self.world.n_collectives, dtype=np.int64))

    monkeypatch.setattr(Simulation, "truth", planted)
    _, fooled = run_trial(scenario, "M1", PARAMS, SyntheticOperator(BUSY, 5), "p", "t", 600.0)
    assert honest.requests and honest.requests == fooled.requests
    assert honest.observations == fooled.observations
    assert honest.decisions == fooled.decisions
    assert [p["truth"] for p in honest.probes] != [p["truth"] for p in fooled.probes]


def test_slips_are_refused_and_every_kind_of_action_happens() -> None:
    _, rows = run_trial(_scenario(13), "M1", PARAMS, SyntheticOperator(BUSY, 7), "p", "t", 900.0)
    kinds = {(r["kind"], r["accepted"]) for r in rows.requests}
    assert {("investigate", True), ("abandon", True)} <= kinds
    assert any(not r["accepted"] for r in rows.requests)  # its slips
    assert {o["kind"] for o in rows.observations} == {"collective", "target"}
    assert rows.probes and all(p["answer"] for p in rows.probes if not p["timed_out"])


def test_a_population_draws_valid_people_that_differ() -> None:
    population = Population(spread=0.8)
    people = [population.participant(seed) for seed in range(50)]
    assert len({p.glance_interval_s for p in people}) == 50
    assert all(p.decide_support >= 0.30 for p in people)
    assert all(0.0 <= p.investigate_prob <= 1.0 for p in people)
    assert population.participant(7) == population.participant(7)
    median = Population(spread=0.0).participant(3).to_dict()
    assert median == pytest.approx(Traits().to_dict())  # no spread: everyone is the median
    never = Population(Traits(redirect_prob=0.0, hasten_prob=1.0), spread=0.8)
    assert {(p.redirect_prob, p.hasten_prob) for p in map(never.participant, range(20))} == {
        (0.0, 1.0)
    }  # a person who never (always) does it: everyone


def test_a_decide_threshold_below_the_interfaces_floor_is_refused() -> None:
    with pytest.raises(ValueError, match="decide_support"):
        Traits(decide_support=0.2)


def _operator(**changes: float) -> SyntheticOperator:
    quiet = {"observe_collective_prob": 0.0, "observe_target_prob": 0.0, "slip_prob": 0.0}
    return SyntheticOperator(Traits(**(quiet | changes)), 1)


def _attended_after_acting(stay_prob: float) -> list[tuple[int, int]]:
    """(collective attended, the next look's collective) for looks that sent a request."""
    sim = Simulation(_scenario(21), "M3", PARAMS)
    sim.step(600)
    operator = _operator(stay_prob=stay_prob, investigate_prob=1.0, decide_prob=0.0)
    pairs, previous = [], None
    for _ in range(24):
        glance = operator.look(sim.display())
        if previous is not None:
            pairs.append((previous, glance.collective))
        previous = glance.collective if glance.commands else None
        sim.step(20)
    return pairs


def test_attention_stays_on_a_collective_it_has_just_acted_on_as_often_as_the_person_does() -> None:
    staying, moving = _attended_after_acting(1.0), _attended_after_acting(0.0)
    assert staying and moving
    assert all(before == after for before, after in staying)
    assert all(before != after for before, after in moving)


def _pushes(model: str, stall_window_s: float) -> list[float]:
    """When a person who never investigates in the ordinary way pushes collectives."""
    traits = Traits(
        glance_interval_s=2.0,
        investigate_prob=0.0,
        stalled_investigate_prob=1.0,
        stall_window_s=stall_window_s,
        decide_prob=0.0,
        abandon_prob=0.0,
        slip_prob=0.0,
    )
    operator = SyntheticOperator(traits, 2)
    _, rows = run_trial(_scenario(22), model, PARAMS, operator, "p", "t", 400.0, probes=False)
    return [r["sim_time_s"] for r in rows.requests if r["kind"] == "investigate"]


def test_collectives_that_never_move_by_themselves_are_pushed_without_waiting() -> None:
    """In M3 nothing gains support unpushed, so the person pushes at once, however long
    they would wait for a collective seen to move by itself; in M1, once seen moving by
    itself, a collective is pushed only when it has not grown for the stall window."""
    m3 = _pushes("M3", 300.0)
    m1_patient, m1_hasty = _pushes("M1", 300.0), _pushes("M1", 10.0)
    assert m3 and min(m3) < 30.0
    assert len(m3) > len(m1_patient)
    assert len(m1_hasty) > len(m1_patient)


def test_a_moving_collective_is_the_persons_next_decision_as_the_probe_scores_it() -> None:
    """Level 3 from what it saw: a decision ends when the collective lands (the platform
    scores a projection by the next decision to end), so a collective on the move is the
    answer; the simulation run on confirms it ends first."""
    sim = Simulation(_scenario(23), "M1", PARAMS)
    while not sim.display().executing.any():
        sim.step(10)
    display = sim.display()
    operator = _operator(projection_lapse=0.0)
    operator.look(display)
    names = ["I", "II", "III", "IV"]
    moving = {names[c] for c in np.flatnonzero(display.executing)}
    answer = operator.answer(3, "Which collective will make the next decision?", names)
    assert answer in moving
    ended = len(sim.decisions)
    while len(sim.decisions) == ended:
        sim.step(10)
    assert names[sim.decisions[ended].collective] == answer


def test_of_targets_that_look_equally_good_the_nearer_is_the_best_choice() -> None:
    """Level 2 and the requests: two targets a person cannot tell apart by their green
    (within `value_resolution`) are ranked by distance to the hub."""
    sim = Simulation(_scenario(24), "M1", PARAMS)
    sim.step(200)
    assert not sim.finished
    view = sim.display().to_json()
    hub = np.array(view["collectives"][0]["hub"], dtype=float)
    targets = view["targets"]
    assert len(targets) >= 2
    far, near = targets[0], targets[1]
    near["value"], far["value"] = 0.9, 0.91  # the far one reads a shade greener
    for t in targets[2:]:
        t["value"] = 0.5

    def distance(t: dict) -> float:
        return float(np.hypot(*(np.array(t["position"], dtype=float) - hub)))

    if distance(near) > distance(far):
        near["position"], far["position"] = far["position"], near["position"]
    display = Display.from_json(view)
    question = "Which target is the best choice for collective I?"
    choices = [str(far["id"]), str(near["id"])]
    sharp = _operator(value_noise=1e-6, value_resolution=0.001, comprehension_lapse=0.0)
    blurred = _operator(value_noise=1e-6, value_resolution=0.05, comprehension_lapse=0.0)
    sharp.look(display)
    blurred.look(display)
    assert sharp.answer(2, question, choices) == str(far["id"])
    assert blurred.answer(2, question, choices) == str(near["id"])


def _requests(model: str, seeds: tuple[int, int], duration_s: float, **traits: float) -> list:
    """The requests of a quiet person (no clicks, no slips, no abandons) who pushes stuck
    collectives at every look, over a trial without probes; seeds: scenario, operator."""
    quiet = dict(
        glance_interval_s=2.0,
        stalled_investigate_prob=1.0,
        abandon_prob=0.0,
        slip_prob=0.0,
        observe_collective_prob=0.0,
        observe_target_prob=0.0,
    )
    operator = SyntheticOperator(Traits(**(quiet | traits)), seeds[1])
    scenario = _scenario(seeds[0])
    _, rows = run_trial(scenario, model, PARAMS, operator, "p", "t", duration_s, probes=False)
    return rows.requests


def _m3_investigates(**changes: float) -> list[dict]:
    """The investigates a person pushing M3's collectives sends in 300 s, with these traits."""
    sent = _requests("M3", (25, 4), 300.0, **({"decide_prob": 0.0} | changes))
    return [r for r in sent if r["kind"] == "investigate"]


def test_a_burst_sends_what_the_threshold_needs_up_to_the_persons_most_and_waits_for_them() -> None:
    """From no support, 40% needs 8 investigates of 10 agents: a person who presses Commit
    at most 6 times sends 6 together; at 30%, 6 of at most 8. Then none for that target
    until they have landed, and none while the list shows agents still to come."""
    for decide_support, most, expected in ((0.4, 6.0, 6), (0.3, 8.0, 6), (0.4, 1.0, 1)):
        sent = _m3_investigates(decide_support=decide_support, investigate_burst=most)
        first = [
            r
            for r in sent
            if (r["collective"], r["target"]) == (sent[0]["collective"], sent[0]["target"])
        ]
        assert sum(r["sim_time_s"] == first[0]["sim_time_s"] for r in first) == expected
        gaps = [b["sim_time_s"] - a["sim_time_s"] for a, b in zip(first, first[1:], strict=False)]
        assert all(g == 0 or g >= 2.0 for g in gaps)  # never again within a glance of a burst
    one_by_one = _m3_investigates(decide_support=0.4, investigate_burst=1.0)
    assert len(_m3_investigates(decide_support=0.4, investigate_burst=6.0)) < 3 * len(one_by_one)


def test_a_push_aims_its_margin_past_the_threshold() -> None:
    """A person who has seen a push shed below 30% before they could decide aims past it:
    from no support, 30% and a margin of 0.05 need 7 investigates where 30% alone needs 6,
    and a margin of 0.12 needs 9, of which a person pressing Commit at most 8 times sends 8.
    A margin is a share of the collective: a negative one is refused."""
    for margin, expected in ((0.0, 6), (0.05, 7), (0.12, 8)):
        sent = _m3_investigates(decide_support=0.3, investigate_burst=8.0, push_margin=margin)
        first = [r for r in sent if r["sim_time_s"] == sent[0]["sim_time_s"]]
        assert len(first) == expected, margin
    with pytest.raises(ValueError, match="push_margin"):
        Traits(push_margin=-0.01)


@pytest.mark.parametrize(
    "changes",
    [
        {"glance_interval_s": math.nan},  # a person who never looks
        {"survey_s": math.inf},
        {"stay_prob": True},  # a probability, not a yes
        {"value_noise": "0.01"},
    ],
)
def test_a_trait_that_is_not_a_finite_number_is_refused_by_name(changes: dict) -> None:
    """Every path that makes a person (a population file, a --start file, the HTTP bot's
    caller) meets the same check: a trait is a finite number, named when it is not."""
    (name,) = changes
    with pytest.raises(ValueError, match=f"{name} must be a finite number"):
        Traits(**changes)
    with pytest.raises(ValueError, match="spread must be a finite number"):
        Population(Traits(), math.nan)


def test_a_person_who_surveys_first_sends_no_investigate_before_the_survey_is_over() -> None:
    """At the start of a decision (here the trial's start) a surveying person looks before
    pushing: no investigate in the first `survey_s`; an unhurried one pushes within 30 s."""
    assert min(r["sim_time_s"] for r in _m3_investigates(survey_s=1.0)) < 30.0
    assert min(r["sim_time_s"] for r in _m3_investigates(survey_s=90.0)) >= 90.0


def test_deciding_for_a_collective_that_moves_by_itself_is_its_own_chance() -> None:
    """`decide_prob` is for a collective that looks stuck (M3's never move by themselves);
    `hasten_prob` for one seen moving by itself: with it at 0, M1's collectives are decided
    for only when stuck, so fewer decides than with it at 1."""

    def decides(model: str, **changes: float) -> int:
        traits = dict(investigate_prob=0.5, stall_window_s=120.0, decide_support=0.3)
        sent = _requests(model, (26, 6), 600.0, **(traits | changes))
        return sum(r["kind"] == "decide" for r in sent)

    assert decides("M3", decide_prob=1.0, hasten_prob=0.0) > 0
    assert decides("M3", decide_prob=0.0, hasten_prob=1.0) == 0
    assert decides("M1", decide_prob=1.0, hasten_prob=0.0) < decides(
        "M1", decide_prob=1.0, hasten_prob=1.0
    )


def test_attention_stays_while_the_persons_own_investigates_are_still_landing() -> None:
    """A person who has just pushed a collective watches the push land: with `stay_prob`
    1 the looks after a burst stay on that collective while the burst has not landed,
    though they send nothing; with 0 attention moves on at once."""

    def after_burst(stay_prob: float) -> list[int | None]:
        sim = Simulation(_scenario(27), "M3", PARAMS)
        sim.step(100)
        operator = _operator(
            stay_prob=stay_prob,
            stalled_investigate_prob=1.0,
            investigate_burst=6.0,
            decide_prob=0.0,
            reaction_time_s=8.0,
        )
        while not (glance := operator.look(sim.display())).commands:
            sim.step(10)
        pushed = glance.collective
        return [pushed] + [operator.look(sim.display()).collective for _ in range(3)]

    staying, moving = after_burst(1.0), after_burst(0.0)
    assert staying == [staying[0]] * 4
    assert moving[1] != moving[0]


def test_a_person_who_has_seen_collectives_move_by_themselves_nudges_one_at_a_time() -> None:
    """Pushing (a burst, after watching the target for `survey_s`) is for a collective that
    looks stuck; one seen moving by itself gets a nudge: one investigate a look, at once. In
    M1 a person who never pushes still nudges; in M3 (nothing moves by itself) the same
    person sends nothing while it watches."""
    person = dict(
        investigate_prob=1.0,
        stalled_investigate_prob=1.0,
        stall_window_s=1e6,
        investigate_burst=6.0,
        survey_s=1e6,
        decide_prob=0.0,
        hasten_prob=0.0,
    )
    nudges = [r for r in _requests("M1", (28, 7), 400.0, **person) if r["kind"] == "investigate"]
    assert len(nudges) >= 5
    per_look = Counter((r["sim_time_s"], r["collective"]) for r in nudges)
    assert max(per_look.values()) == 1
    assert not [r for r in _requests("M3", (28, 7), 400.0, **person) if r["kind"] == "investigate"]


def test_a_target_is_watched_from_when_it_appears_before_it_is_pushed() -> None:
    """`survey_s` counts from the decision's start or from when the target was first drawn,
    whichever is later: a target found late (a difficult decision's far best one) is not
    pushed until the person has watched it that long."""
    survey_s = 60.0
    operator = SyntheticOperator(
        Traits(
            glance_interval_s=2.0,
            stalled_investigate_prob=1.0,
            survey_s=survey_s,
            decide_prob=0.0,
            abandon_prob=0.0,
            slip_prob=0.0,
        ),
        8,
    )
    sim = Simulation(_scenario(29), "M3", PARAMS)
    appeared: dict[int, float] = {}
    pushed: list[tuple[float, int]] = []
    while sim.time < 400.0:
        display = sim.display()
        for target, drawn in zip(display.target_ids.tolist(), display.drawn.tolist(), strict=True):
            if drawn:
                appeared.setdefault(int(target), display.time)
        glance = operator.look(display)
        pushed += [(display.time, c.target) for c in glance.commands if c.kind == "investigate"]
        sim.step(round(2.0 / PARAMS.dt_s))
    assert pushed
    assert max(appeared[t] for _, t in pushed) > 0.0  # some pushed target appeared late
    assert all(at - appeared[t] >= survey_s for at, t in pushed)


def test_a_person_names_the_collective_it_is_bringing_to_a_decision_as_the_next() -> None:
    """Level 3 with none on the move: in M3 only the person's requests decide, so the next
    decision is one it is bringing about: the first it decided for, else the first it
    pushed (its push landed first). The names follow its requests until a decision ends,
    and the last names the collective whose decision ends first."""
    sim = Simulation(_scenario(30), "M3", PARAMS)
    operator = _operator(
        stay_prob=0.0,
        stalled_investigate_prob=1.0,
        investigate_burst=8.0,
        decide_support=0.3,
        decide_prob=1.0,
        projection_lapse=0.0,
    )
    names = ["I", "II", "III", "IV"]
    question = "Which collective will make the next decision?"
    pushed: list[int] = []
    decided: list[int] = []
    expected = None
    while not sim.decisions:
        glance = operator.look(sim.display())
        for command in glance.commands:  # sent, whether the simulation takes them or not
            sim.apply(command)
            (pushed if command.kind == "investigate" else decided).append(command.collective)
        if pushed:
            expected = decided[0] if decided else pushed[0]
            assert operator.answer(3, question, names) == names[expected]
        sim.step(10)
    assert decided and sim.decisions[0].collective == expected  # the simulation agrees


def test_a_target_is_looked_up_on_the_looks_that_act_on_it() -> None:
    """A target click comes with a request, on that request's target: a person who never
    requests never clicks a target, whatever `observe_target_prob`; one who requests on
    some looks clicks the target of each such look's first request, on those looks only."""
    clicks = dict(observe_target_prob=1.0, observe_collective_prob=0.0, slip_prob=0.0)
    idle = dict(investigate_prob=0.0, stalled_investigate_prob=0.0, abandon_prob=0.0)
    sim = Simulation(_scenario(31), "M3", PARAMS)
    watcher = SyntheticOperator(Traits(**(clicks | idle | {"decide_prob": 0.0})), 9)
    worker = SyntheticOperator(Traits(**(clicks | {"stalled_investigate_prob": 0.5})), 9)
    acted = 0
    while sim.time < 300.0:
        display = sim.display()
        assert not watcher.look(display).observations
        glance = worker.look(display)
        targets = [o.target for o in glance.observations if o.kind == "target"]
        assert targets == ([glance.commands[0].target] if glance.commands else [])
        acted += bool(glance.commands)
        sim.step(round(2.0 / PARAMS.dt_s))
    assert acted >= 3


def test_before_any_push_a_person_names_the_collective_it_will_push_first() -> None:
    """Level 3 while the person watches M3's collectives before pushing (a long `survey_s`):
    the next to decide is the one it will push first, whose best-looking target (here the
    greenest in its range) it has watched longest; the answer follows the map as targets
    appear."""
    sim = Simulation(_scenario(32), "M3", PARAMS)
    operator = _operator(
        stay_prob=0.0,
        value_noise=1e-9,
        value_resolution=1e-9,
        survey_s=1e6,
        projection_lapse=0.0,
    )
    names = ["I", "II", "III", "IV"]
    appeared: dict[int, float] = {}
    watched: dict[int, float] = {}
    while sim.time < 240.0:
        display = sim.display()
        for target, drawn in zip(display.target_ids.tolist(), display.drawn.tolist(), strict=True):
            if drawn:
                appeared.setdefault(int(target), display.time)
        glance = operator.look(display)
        assert not glance.commands
        c = glance.collective
        shown = np.flatnonzero(display.in_range[c] & display.drawn)
        if shown.size:
            best = shown[int(np.argmax(np.asarray(display.value)[shown]))]
            watched[c] = appeared[int(display.target_ids[best])]
        if watched:
            first = min(watched, key=lambda k: watched[k])
            answer = operator.answer(3, "Which collective will make the next decision?", names)
            assert answer == names[first]
        sim.step(round(2.0 / PARAMS.dt_s))
    assert watched


def test_a_collective_that_has_just_landed_is_not_the_one_watched_longest() -> None:
    """Level 3 before any push: a collective that has landed begins a new decision whose
    targets the person has not watched yet, so what it watched in the decision before does
    not make it the one the person will push first. Three displays of one M3 map: at 60 s
    only collective I has targets in range; at 120 s all have; at 200 s I has landed and
    attention is on II."""
    sim = Simulation(_scenario(33), "M3", PARAMS)
    sim.step(round(60.0 / PARAMS.dt_s))
    real = sim.display()
    assert real.drawn.any()
    quiet = dict(support=np.zeros_like(real.support))
    in_range, drawn = real.in_range.copy(), real.drawn.copy()
    in_range[1:] = False
    drawn[~real.in_range[0]] = False  # II-IV's targets are drawn later
    first = replace(real, in_range=in_range, drawn=drawn, **quiet)
    assert (in_range[0] & drawn).any()
    later = replace(real, time=120.0, **quiet)
    moved = later.hub.copy()
    moved[0] += 100.0
    landed = replace(later, time=200.0, hub=moved)
    operator = _operator(stay_prob=0.0, survey_s=1e6, projection_lapse=0.0)
    names = ["I", "II", "III", "IV"]
    question = "Which collective will make the next decision?"
    for display in [first] * 4 + [later] * 5:  # each collective attended, then I once more
        assert not operator.look(display).commands
    assert operator.answer(3, question, names) == "I"  # watched since 60 s, the others 120 s
    assert operator.look(landed).collective == 1
    assert operator.answer(3, question, names) != "I"


def test_a_person_takes_back_agents_it_sent_to_a_target_that_no_longer_looks_best() -> None:
    """`redirect_prob`: a person who pushed the best target it had seen, and then sees a
    better one, abandons the one it pushed (its agents are still there: an intervention at
    10% support). Targets it did not send agents to, and those it sent in a decision that
    has ended, are not its to take back. Crafted from one M3 map: collective I has targets
    a (0.7) and b (0.9); b is drawn only on the second display, when a holds 12% support."""
    sim = Simulation(_scenario(34), "M3", PARAMS)
    sim.step(round(60.0 / PARAMS.dt_s))
    real = sim.display()
    a, b = (int(v) for v in np.flatnonzero(real.in_range[0])[:2])
    ids = real.target_ids.tolist()
    in_range = np.zeros_like(real.in_range)
    in_range[0, [a, b]] = True
    value = np.asarray(real.value, dtype=float).copy()
    value[[a, b]] = (0.7, 0.9)
    drawn = np.zeros_like(real.drawn)
    drawn[a] = True
    quiet = np.zeros_like(real.support)
    only_a = replace(real, in_range=in_range, value=value, drawn=drawn, support=quiet, requests=())
    held = quiet.copy()
    held[0, a] = 0.12
    both = replace(only_a, time=90.0, drawn=drawn | (np.arange(drawn.size) == b), support=held)
    moved = both.hub.copy()
    moved[0] += 100.0
    landed = replace(both, time=120.0, hub=moved)

    def abandons(redirect_prob: float, survey_s: float, displays: list[Display]) -> list[int]:
        """The targets of I that the person abandons; with no survey it pushes a first."""
        operator = _operator(
            stay_prob=0.0,
            value_noise=1e-9,
            stalled_investigate_prob=1.0,
            survey_s=survey_s,
            decide_prob=0.0,
            abandon_prob=0.0,
            redirect_prob=redirect_prob,
        )
        sent = []
        for display in displays:
            for _ in range(4):  # I, then II-IV (nothing in their range)
                sent += [c for c in operator.look(display).commands if c.collective == 0]
        if not survey_s:
            assert sent[0].kind == "investigate" and sent[0].target == ids[a]
        return [c.target for c in sent if c.kind == "abandon"]

    assert abandons(1.0, 0.0, [only_a, both]) == [ids[a]]
    assert abandons(0.0, 0.0, [only_a, both]) == []
    assert abandons(1.0, 1e6, [only_a, both]) == []  # it never pushed a
    assert abandons(1.0, 0.0, [only_a, landed]) == []  # a was pushed in I's last decision


def test_a_hub_is_checked_on_the_look_that_finds_a_better_target_in_sight() -> None:
    """With `observe_change_prob` 1 and no other hub clicks: a click on the look at a
    collective whose best-looking target differs from the last look's in its decision,
    and on no other; a first look, or the first look after the collective has landed,
    has nothing to differ from."""
    sim = Simulation(_scenario(24), "M1", PARAMS)
    sim.step(200)
    view = sim.display().to_json()
    targets = view["targets"]
    assert len(targets) >= 2 and not sim.display().executing[0]
    for t in targets:
        t["value"] = 0.5
    person = _operator(
        observe_collective_prob=0.0, observe_change_prob=1.0, value_noise=1e-6, stay_prob=0.0
    )
    n = sim.display().n_collectives

    def look_at_first(values: dict[int, float], hub_shift: float = 0.0) -> bool:
        """One round of looks (one at each collective); whether collective 0's hub was
        clicked."""
        for t in targets:
            t["value"] = values.get(t["id"], 0.5)
        view["collectives"][0]["hub"][0] += hub_shift
        clicked = False
        for _ in range(n):
            glance = person.look(Display.from_json(view))
            clicked |= glance.collective == 0 and any(
                o.kind == "collective" for o in glance.observations
            )
        return clicked

    first, second = targets[0]["id"], targets[1]["id"]
    assert not look_at_first({first: 0.9})  # the first look: nothing to differ from
    assert not look_at_first({first: 0.9})  # the same target still looks best
    assert look_at_first({first: 0.9, second: 1.0})  # a better one has come in sight
    assert not look_at_first({first: 0.9, second: 1.0})
    assert not look_at_first({first: 1.0}, hub_shift=50.0)  # landed: a new decision


def test_hub_and_target_clicks_change_no_request_and_no_decision() -> None:
    """Observation clicks reach no collective: people who differ only in how often they
    click send the same requests and the collectives make the same decisions, so the
    observation traits can be fitted without moving any other cell."""

    def trial(**clicks: float) -> tuple[list, list, int]:
        operator = SyntheticOperator(replace(BUSY, slip_prob=0.0, **clicks), 6)
        sim, rows = run_trial(_scenario(27), "M2", PARAMS, operator, "p", "t", 400.0)
        requests = [
            (r["sim_time_s"], r["kind"], r["collective"], r["target"]) for r in rows.requests
        ]
        return requests, [d.as_row() for d in sim.decisions], len(rows.observations)

    quiet = trial(observe_collective_prob=0.0, observe_target_prob=0.0, observe_change_prob=0.0)
    clicking = trial(observe_collective_prob=0.3, observe_target_prob=0.9, observe_change_prob=1.0)
    assert quiet[:2] == clicking[:2] and quiet[0] and quiet[1]
    assert quiet[2] == 0 < clicking[2]
