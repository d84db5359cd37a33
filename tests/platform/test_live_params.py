"""A participant's trial runs the batch experiment's model: the same params but the time-out."""

from __future__ import annotations

from dataclasses import fields

from hcss.simulation import Params


def test_a_live_m2_trial_uses_the_batch_defaults_apart_from_the_decision_timeout(
    make_trial,  # type: ignore[no-untyped-def]
) -> None:
    handle = make_trial(model="M2")
    live = handle.live()
    live_params, batch = live.sim.params, Params()
    differing = [
        f.name for f in fields(Params) if getattr(live_params, f.name) != getattr(batch, f.name)
    ]
    assert differing == ["decision_timeout_s"]
    assert live_params.decision_timeout_s is None
    # The calibrations and the readings the study file records are the batch ones.
    stored = live.sim.params.to_dict()
    for name in (
        "discovery",
        "sensing_radius_m",
        "message_rate",
        "m2_distance_bounds",
        "m2_beyond_dmax",
        "foreign_targets",
        "m2_mechanisms",
    ):
        assert stored[name] == batch.to_dict()[name]
