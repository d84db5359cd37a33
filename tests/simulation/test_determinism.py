"""Snapshots, restores and replays continue bit for bit (spec §9, Determinism)."""

from __future__ import annotations

import math
import pickle
import re
from pathlib import Path

import numpy as np
import pytest

from hcss.simulation import Params, Scenario, Simulation, SimulationError
from hcss.simulation.operators import InvestigateThenDecide, OperatedRun
from hcss.simulation.replay import replay


def _assert_same_world(a: Simulation, b: Simulation) -> None:
    for name, array in a.world.arrays().items():
        np.testing.assert_array_equal(array, b.world.arrays()[name], err_msg=name)
    assert a.state_digest() == b.state_digest()


@pytest.mark.parametrize("model", ["M1", "M2", "M3"])
def test_restore_continues_bit_identically(model):
    sim = Simulation(Scenario.generate(21), model)
    sim.step(300)
    if model == "M3":
        visible = sim.view()["targets"]
        sim.investigate(0, visible[0]["id"]) if visible else None
    blob = sim.snapshot()
    restored = Simulation.restore(blob)
    _assert_same_world(sim, restored)
    sim.step(500)
    restored.step(500)
    _assert_same_world(sim, restored)
    assert [d.as_row() for d in sim.decisions] == [d.as_row() for d in restored.decisions]


def test_same_scenario_and_run_give_the_same_trial_and_other_runs_differ():
    a = Simulation(Scenario.generate(4), "M2", run=0)
    b = Simulation(Scenario.generate(4), "M2", run=0)
    c = Simulation(Scenario.generate(4), "M2", run=1)
    for sim in (a, b, c):
        sim.step(400)
    _assert_same_world(a, b)
    assert a.state_digest() != c.state_digest()
    np.testing.assert_array_equal(
        a.world.target_pos, c.world.target_pos
    )  # replicates share the layout


def test_replaying_a_timed_request_log_reproduces_an_operated_trial():
    scenario = Scenario.generate(12, first_section="difficult")
    operated = OperatedRun(Simulation(scenario, "M3"), InvestigateThenDecide(), interval_s=15)
    operated.run(until_s=900)
    assert len(operated.log) > 5 and any(
        kind == "decide" for kind in (c.kind for _, c in operated.log)
    )
    replayed = replay(scenario, "M3", operated.log, until_step=operated.sim.step_count)
    _assert_same_world(operated.sim, replayed)


def test_replay_from_a_snapshot_skips_commands_it_already_contains():
    scenario = Scenario.generate(13)
    operated = OperatedRun(Simulation(scenario, "M1"), InvestigateThenDecide(), interval_s=10)
    operated.run(until_s=200)
    blob = operated.sim.snapshot()
    in_snapshot = operated.sim.commands_applied
    operated.run(until_s=500)
    heard: list[int] = []
    resumed = replay(
        scenario,
        "M1",
        operated.log,
        until_step=operated.sim.step_count,
        start=Simulation.restore(blob),
        on_outcome=lambda i, outcome: heard.append(i),
    )
    _assert_same_world(operated.sim, resumed)
    # Only the commands after the snapshot are replayed, each reported once, in log order.
    assert heard == list(range(in_snapshot, len(operated.log)))
    assert len(operated.log) > in_snapshot > 0


def test_replay_shows_each_step_once_after_its_commands():
    """`on_step` (the console replay's frames): every step from the start's, commands applied."""
    scenario = Scenario.generate(13)
    operated = OperatedRun(Simulation(scenario, "M1"), InvestigateThenDecide(), interval_s=10)
    operated.run(until_s=120)
    seen: list[tuple[int, int]] = []

    def step(sim: Simulation) -> None:
        seen.append((sim.step_count, sim.commands_applied))

    until = operated.sim.step_count
    replay(scenario, "M1", operated.log, until_step=until, on_step=step)
    assert [s for s, _ in seen] == list(range(until + 1))
    for s, applied in seen:  # every command logged at or before the step is in it
        assert applied == sum(1 for logged, _ in operated.log if logged <= s)
    middle = replay(scenario, "M1", operated.log, until_step=until // 2)
    seen.clear()
    replay(scenario, "M1", operated.log, until_step=until, start=middle, on_step=step)
    assert [s for s, _ in seen] == list(range(until // 2, until + 1))


def test_garbage_is_not_a_snapshot():
    with pytest.raises(SimulationError):
        Simulation.restore(b"not a pickle")


@pytest.mark.parametrize("model", ["M1", "M2", "M3"])
def test_steps_run_in_one_compiled_call_equal_steps_taken_one_by_one(model):
    """The engine runs quiet steps inside one kernel call; the trial must not notice.

    M3 without an operator times its decisions out, so the time-out path is covered.
    """
    batched = Simulation(Scenario.generate(5), model)
    single = Simulation(Scenario.generate(5), model)
    batched.run_until_finished(max_steps=2500)
    while not single.finished and single.step_count < 2500:
        single._step_once()  # the two-call path, one step at a time
    _assert_same_world(batched, single)
    assert batched.drain_events() == single.drain_events()
    assert len(batched.decisions) >= 2


def test_the_state_digest_covers_the_parameters():
    """Two trials alike but for a parameter (a decision timeout) are not the same state."""
    scenario = Scenario.generate(5)
    live = Simulation(scenario, "M2", Params().with_changes(decision_timeout_s=None))
    default = Simulation(scenario, "M2", Params())
    assert live.state_digest() != default.state_digest()
    again = Simulation(scenario, "M2", Params().with_changes(decision_timeout_s=None))
    assert live.state_digest() == again.state_digest()


def test_a_snapshot_from_before_the_status_queue_restores_and_continues():
    """Trials snapshotted by the previous release (no status queue) rebuild after an upgrade."""
    operated = OperatedRun(Simulation(Scenario.generate(8), "M1"), InvestigateThenDecide())
    operated.run(until_s=120)
    sim = operated.sim
    assert sim.requests, "the snapshot must hold requests"
    state = pickle.loads(sim.snapshot())
    del state["status_changes"]
    for request in state["requests"]:
        del request.__dict__["noted"]
    old = Simulation.restore(pickle.dumps(state))
    assert old.state_digest() == sim.state_digest()
    old.step(60)
    sim.step(60)
    assert old.state_digest() == sim.state_digest()
    # Its requests' earlier statuses may be queued again; the platform writes each once.
    assert {c.status for c in old.drain_status_changes()} <= {"in_progress", "completed", "removed"}


def test_the_discovery_rate_is_the_same_bits_on_every_machine():
    """g(d) and M2's wait gap are libm's exp, not numpy's: numpy picks its exp by CPU (an
    AVX-512 machine's differs from libm in the last bit for about 5% of arguments), so a
    trial rebuilt on another host, or a release's snapshot fixture replayed on another
    machine, drifted from the stored state (test_snapshot_compat failed on an AMD EPYC
    with AVX-512 against fixtures written on a machine without it)."""
    params = Params()
    distances = np.linspace(params.hub_radius_m, 1500.0, 20_001)
    in_units = [float(d) / params.discovery_unit_m for d in distances]
    with_libm = [params.discovery_mu * math.exp(params.discovery_xi * d) / d for d in in_units]
    assert np.asarray(params.discovery_rate(distances)).tolist() == with_libm
    assert params.discovery_rate(float(distances[7])) == with_libm[7]


def test_the_model_calls_none_of_numpy_s_cpu_dispatched_transcendentals():
    """The model's exp, sin and cos are libm's (`math`, or the compiled kernels' calls):
    numpy's float64 exp, log, sin, cos, tan, arctan2 and power pick an implementation by
    CPU, so a scenario's layout or a rate could differ between two hosts of one trial."""
    import hcss.simulation

    package = Path(hcss.simulation.__file__).parent
    dispatched = re.compile(r"np\.(exp|expm1|log|log1p|log2|log10|sin|cos|tan|arctan2|power)\(")
    found = [
        f"{path.name}:{number}"
        for path in sorted(package.glob("*.py"))
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if dispatched.search(line)
    ]
    assert found == []
