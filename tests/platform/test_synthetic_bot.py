"""One synthetic operator, two paths: in process through Simulation.apply, and over the page's
own HTTP protocol (the stream with ?after=, keyed commands, probes in their window)."""

from __future__ import annotations

from typing import Any

from flask import Flask

from hcss.experiments.synthetic_trials import run_trial
from hcss.platform.bots.synthetic import SyntheticBot
from hcss.platform.models import Command
from hcss.simulation.synthetic import SyntheticOperator, Traits
from tests.support.counting import count_rows

PACE = Traits(
    glance_interval_s=3.0,
    reaction_time_s=2.0,
    investigate_prob=0.6,
    stalled_investigate_prob=0.8,
    investigate_burst=3.0,  # several investigates from one look: sent one after another
    survey_s=10.0,
    decide_prob=0.6,
    hasten_prob=0.3,
    abandon_prob=0.6,
    abandon_support=0.08,
    abandon_gap=0.08,
    slip_prob=0.2,
    observe_collective_prob=0.4,
    observe_target_prob=0.3,
)
SUPERVISED_S = 420.0


def _bot(trial: Any, seed: int, **options: Any) -> SyntheticBot:
    return SyntheticBot(
        trial.client,
        trial.api,
        trial.csrf,
        SyntheticOperator(PACE, seed),
        duration_s=SUPERVISED_S,
        move_clock=trial.run_to,
        **options,
    )


def test_both_paths_give_the_same_requests_and_decisions(make_trial) -> None:
    trial = make_trial(seed=31, model="M1")
    live_sim = trial.live().sim
    scenario, params, model = live_sim.scenario, live_sim.params, live_sim.model
    log = _bot(trial, seed=5).supervise()
    over_http = [
        (r["step"], r["kind"], r["collective"], r["target"], bool(r["answer"].get("accepted")))
        for r in log.requests
    ]
    live_decisions = [d.as_row() for d in trial.live().sim.decisions]

    sim, rows = run_trial(
        scenario, model, params, SyntheticOperator(PACE, 5), "p", "t", SUPERVISED_S
    )
    in_process = [
        (round(r["sim_time_s"] / params.dt_s), r["kind"], _index(r["collective"]), r["target"],
         r["accepted"])
        for r in rows.requests
    ]  # fmt: skip
    assert len(over_http) > 20 and any(not accepted for *_, accepted in over_http)
    assert over_http == in_process
    assert [d.as_row() for d in sim.decisions] == live_decisions[: len(sim.decisions)]
    assert len(sim.decisions) >= 2
    steps = [step for step, kind, *_ in over_http if kind == "investigate"]
    assert max(steps.count(s) for s in steps) > 1  # a burst went over HTTP too
    assert log.observations and log.probes  # it clicked and answered probes, over HTTP too


def test_every_command_is_keyed_and_a_lost_answer_is_sent_again_once(
    app: Flask, make_trial
) -> None:
    """A proxy that loses every first answer (502 after the app carried the command out):
    the bot sends the same key again, and each command is stored once."""
    trial = make_trial(seed=32, model="M2")
    lost: set[str] = set()
    real_post = trial.client.post

    def post_through_a_losing_proxy(url: str, **kwargs: Any) -> Any:
        response = real_post(url, **kwargs)
        key = kwargs["headers"]["Idempotency-Key"]
        if key not in lost:
            lost.add(key)
            response.status_code = 502
        return response

    trial.client.post = post_through_a_losing_proxy  # type: ignore[method-assign]
    waits: list[float] = []
    bot = _bot(trial, seed=6, sleep=waits.append)
    bot.duration_s = 180.0
    log = bot.supervise()
    sent = len(log.requests) + len(log.observations) + 2 * len(log.probes)
    assert sent > 10 and len(log.keys) >= sent and len(set(log.keys)) == len(log.keys)
    assert log.retries == len(log.keys)  # every command's first answer was lost
    assert waits and all(w == 0.5 for w in waits)
    assert count_rows(app, Command) == len(log.requests)


def _index(name: str | None) -> int | None:
    return None if name is None else ("I", "II", "III", "IV").index(name)
