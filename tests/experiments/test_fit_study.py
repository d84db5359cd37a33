"""The study calibration: targets, loss, presets and `hcss simulate calibrate --to study`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import fit_study as fs
from hcss.experiments import study_targets as st
from hcss.simulation.params import Params
from hcss.simulation.presets import DEFAULT_PRESET, PRESETS, preset_params


def _row(model: str, split: str, trial: str, correct: bool, seconds: float) -> dict:
    return {
        "model": model,
        "difficulty": split,
        "trial_id": trial,
        "correct": correct,
        "decision_time_s": seconds,
    }


def test_measure_pools_decisions_and_takes_standard_errors_over_trials() -> None:
    rows = [
        _row("M1", "easy", "a", True, 120),
        _row("M1", "easy", "a", False, 240),
        _row("M1", "easy", "b", True, 60),
    ]
    m = st.measure(rows)[("M1", "easy")]
    # By hand: 2 of 3 decisions correct; times 2, 4 and 1 minutes.
    assert m.decisions == 3
    assert m.success_pct == pytest.approx(200 / 3)
    assert m.time_min == pytest.approx(7 / 3)
    # Trial means: success 50 and 100 (sd 35.355, se 25); time 3 and 1 (sd 1.4142, se 1).
    assert m.success_se == pytest.approx(25.0)
    assert m.time_se == pytest.approx(1.0)


def test_loss_is_squared_distance_in_bands_and_counts_cells_within_them() -> None:
    measured = {
        (t.model, t.split): st.Measured(t.model, t.split, 10, t.success_pct, 0, t.time_min, 0)
        for t in st.STUDY_TARGETS
    }
    assert st.loss(measured) == 0.0
    assert st.cells_met(measured) == 8
    # M2 easy 20 points low (2 bands) and 0.5 min slow (half a band): 4 + 0.25.
    measured[("M2", "easy")] = st.Measured("M2", "easy", 10, 76.7 - 20, 0, 4.17 + 0.5, 0)
    assert st.loss(measured) == pytest.approx(4.25)
    assert st.cells_met(measured) == 7
    del measured[("M1", "difficult")]
    assert st.loss(measured) == float("inf")
    assert "| M1 | difficult | 6.8 | – |" in st.comparison_table(measured)


def test_presets_are_named_in_the_params_they_give_and_share_every_value_across_models() -> None:
    assert set(PRESETS) == {
        "literal",
        "study-calibrated",
        "study-units",
        "study-units-foreign",
        "study-units-eq4",
        "study-units-recruitment",
    }
    assert preset_params("literal") == Params()
    for name, params in PRESETS.items():
        assert params.preset == name
        assert Params.from_dict(json.loads(json.dumps(params.to_dict()))) == params
    # The default is the preset with the lowest out-of-sample loss over the study's tables
    # under its unit (docs/simulation-notes.md); its layout and label readings come with it.
    assert DEFAULT_PRESET == "study-units-foreign"
    assert preset_params().difficulty_label == "best_not_furthest"
    assert preset_params().easy_layout_others == "strictly_farther"
    assert preset_params().foreign_targets == "eligible"
    with pytest.raises(ValueError, match="literal, study-calibrated, study-units"):
        preset_params("bogus")
    # Issue 39's presets differ from study-units only in the readings they are named for
    # (and the recruitment preset's three refitted values): every other value is shared.
    units = preset_params("study-units").to_dict()
    for name, differ in (
        ("study-units-foreign", {"foreign_targets"}),
        ("study-units-eq4", {"m2_modulation_uses"}),
        (
            "study-units-recruitment",
            {"m2_modulation_uses", "message_rate", "fitted_d_max_m", "m2_discovery_wait_scale"},
        ),
    ):
        mine = preset_params(name).to_dict()
        assert {k for k in units if units[k] != mine[k]} == differ | {"preset"}, name


@pytest.mark.parametrize(
    "name", ["study-units-foreign", "study-units-eq4", "study-units-recruitment"]
)
def test_issue_39_presets_reach_the_scenarios_and_the_runs(name: str) -> None:
    """A preset's params reach the scenario generator (its layout readings) and the engine."""
    from hcss.experiments import experiment as exp

    params = preset_params(name)
    scenarios = exp.experiment_scenarios(2, 50_000_000, params)
    # study-units' strictly-farther easy layouts, which all of them keep.
    assert scenarios == exp.experiment_scenarios(2, 50_000_000, preset_params("study-units"))
    assert scenarios != exp.experiment_scenarios(
        2, 50_000_000, params.with_changes(easy_layout_others="anywhere")
    )
    job = exp.jobs_for(scenarios[:1], ("M2",), 1)[0]
    rows = exp.run_job(job, params)
    assert rows != exp.run_job(job, preset_params("study-units"))


def test_an_unknown_preset_is_a_usage_error_on_every_simulate_command() -> None:
    for command in (
        "experiment",
        "fidelity",
        "sweep",
        "calibrate",
        "demo",
        "meanfield",
        "structure",
    ):
        result = CliRunner().invoke(main, ["simulate", command, "--preset", "bogus"])
        assert result.exit_code == 2, command
        assert "Traceback" not in result.output
        assert "literal" in result.output


@pytest.mark.slow
def test_calibrate_to_study_writes_a_fit_a_front_and_importances_and_resumes(
    tmp_path: Path,
) -> None:
    out = tmp_path / "cal"
    args = ["simulate", "calibrate", "--to", "study", "--scenarios", "2", "--runs", "1"]
    args += ["--budget", "4", "--finalists", "1", "--final-runs", "1", "--workers", "1"]
    result = CliRunner().invoke(main, [*args, "--out", str(out)])
    assert result.exit_code == 0, result.output
    fit = json.loads((out / "fit.json").read_text())
    assert set(fit) == set(fs.SEARCH_SPACE)
    report = (out / "report.md").read_text()
    for heading in ("## The fit", "## Pareto front", "## Which values matter"):
        assert heading in report
    assert len((out / "trials.csv").read_text().splitlines()) == 1 + 4
    # A larger budget resumes the search: the 4 trials are kept and 2 more run.
    more = [a if a != "4" else "6" for a in args]
    again = CliRunner().invoke(main, [*more, "--out", str(out)])
    assert again.exit_code == 0, again.output
    assert len((out / "trials.csv").read_text().splitlines()) == 1 + 6
    # Another experiment in the same directory is refused, not mixed in.
    other = [a if a != "2" else "3" for a in args]
    refused = CliRunner().invoke(main, [*other, "--out", str(out)])
    assert refused.exit_code == 2
    assert "another experiment" in refused.output
    assert "Traceback" not in refused.output


def test_the_front_keeps_trials_no_other_beats_on_m1_easy_down_and_m2_easy_up() -> None:
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize")
    # (M1 easy %, M2 easy %): b beats a on both; c and d trade one for the other.
    points = {"a": (90, 50), "b": (85, 55), "c": (95, 70), "d": (70, 40), "e": (96, 69)}
    for name, (m1, m2) in points.items():
        study.add_trial(
            optuna.trial.create_trial(
                params={"r": 1.0},
                distributions={"r": optuna.distributions.FloatDistribution(0, 2)},
                value=1.0,
                user_attrs={"name": name, "m1_easy_success": m1, "m2_easy_success": m2},
            )
        )
    front = [t.user_attrs["name"] for t in fs.pareto_front(study)]
    assert front == ["d", "b", "c"]  # by M1's easy success; a is beaten by b, e by c


def test_a_new_calibration_starts_from_the_presets_under_both_labels(tmp_path: Path) -> None:
    study = fs.open_study(tmp_path / "cal", fs.Settings(budget=1, scenarios=2, runs=1))
    queued = [t.system_attrs["fixed_params"] for t in study.trials]  # enqueued, not yet run
    assert len(queued) == 2 * len(PRESETS)
    for params in PRESETS.values():
        mine = [q for q in queued if q["message_rate"] == params.message_rate]
        assert {q["difficulty_label"] for q in mine} == {"best_nearest", "best_not_furthest"}
        for q in mine:
            assert set(q) == set(fs.SEARCH_SPACE)
            assert fs.params_for(q).m2_d_max_m == q["fitted_d_max_m"]  # valid shared params
    # Reopening does not queue them again.
    assert len(
        fs.open_study(tmp_path / "cal", fs.Settings(budget=1, scenarios=2, runs=1)).trials
    ) == len(queued)


def test_m_i_s_readings_are_in_both_search_spaces_with_r_msg_d_max_and_f_d_s_wait() -> None:
    import optuna

    for name in ("m2_modulation_uses", "m1_queue_modulation", "m2_d_min"):
        assert name in fs.SEARCH_SPACE and name in fs.SPACES["modulation"]
    assert set(fs.SPACES["modulation"]) == {
        "m2_modulation_uses",
        "m1_queue_modulation",
        "m2_d_min",
        "message_rate",
        "fitted_d_max_m",
        "m2_discovery_wait_scale",
    }
    assert len(fs.USES_CHOICES) == 7 and "recruitment+inhibition" in fs.USES_CHOICES
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(sampler=optuna.samplers.RandomSampler(seed=3))
    drawn = [fs.suggest(study.ask(), fs.SPACES["modulation"]) for _ in range(40)]
    assert {d["m2_modulation_uses"] for d in drawn} == set(fs.USES_CHOICES)
    for values in drawn[:5]:
        params = fs.params_for(values, "modulation")
        assert params.m2_modulation_uses == tuple(values["m2_modulation_uses"].split("+"))
        assert params.m1_queue_modulation == values["m1_queue_modulation"]
        assert params.m2_d_min == values["m2_d_min"]
        assert params.message_rate == values["message_rate"]
        # The rest is the default preset's (its layout and label readings too).
        assert params.easy_layout_others == preset_params(DEFAULT_PRESET).easy_layout_others
        assert params.sensing_radius_m == preset_params(DEFAULT_PRESET).sensing_radius_m


def test_the_modulation_space_starts_from_the_default_and_eq_4(tmp_path: Path) -> None:
    settings = fs.Settings(budget=1, scenarios=2, runs=1, space="modulation")
    study = fs.open_study(tmp_path / "cal", settings)
    queued = [t.system_attrs["fixed_params"] for t in study.trials]
    assert queued[0]["m2_modulation_uses"] == "queue+recruitment+inhibition"
    assert {q["m2_modulation_uses"] for q in queued[1:]} == {
        "recruitment+inhibition",
        "recruitment",
    }
    assert all(set(q) == set(fs.SPACES["modulation"]) for q in queued)
    assert fs.params_for(queued[0], "modulation") == preset_params(DEFAULT_PRESET).with_changes(
        m2_distance_bounds="fitted"
    )
    # The full space's manifest differs: the same directory refuses it.
    with pytest.raises(ValueError, match="another experiment or search space"):
        fs.open_study(tmp_path / "cal", fs.Settings(budget=1, scenarios=2, runs=1))


def test_a_search_point_s_readings_reach_the_scenarios_and_the_engine() -> None:
    """The experiment a search trial runs: its scenarios come from its params (the layout
    readings), and its M1 and M2 runs change with M_i's readings."""
    from hcss.experiments import experiment as exp

    values = {
        "m2_modulation_uses": "recruitment",
        "m1_queue_modulation": "modulated",
        "m2_d_min": "search_space",
        "message_rate": 2.047,
        "fitted_d_max_m": 430.0,
        "m2_discovery_wait_scale": 0.153,
    }
    default = fs.params_for(
        values
        | {
            "m2_modulation_uses": "queue+recruitment+inhibition",
            "m1_queue_modulation": "unmodulated",
        },
        "modulation",
    )
    point = fs.params_for(values, "modulation")
    scenarios = exp.experiment_scenarios(1, 20_150_000, point)
    assert scenarios == exp.experiment_scenarios(1, 20_150_000, default)
    assert scenarios != exp.experiment_scenarios(
        1, 20_150_000, point.with_changes(easy_layout_others="anywhere")
    )
    for model in ("M1", "M2"):
        (job,) = exp.jobs_for(scenarios, (model,), 1)
        changed = exp.run_job(job, point)
        assert changed != exp.run_job(job, default), model


def test_the_time_front_keeps_trials_no_other_beats_on_m2_easy_time_down_and_difficult_up() -> None:
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize")
    # (M2 easy time, M2 difficult %): b beats a on both; c and d trade one for the other.
    points = {"a": (5.5, 55), "b": (5.0, 60), "c": (6.0, 70), "d": (4.2, 40), "e": (6.1, 69)}
    for name, (time_min, success) in points.items():
        study.add_trial(
            optuna.trial.create_trial(
                params={"r": 1.0},
                distributions={"r": optuna.distributions.FloatDistribution(0, 2)},
                value=1.0,
                user_attrs={
                    "name": name,
                    "m2_easy_time": time_min,
                    "m2_difficult_success": success,
                },
            )
        )
    front = [t.user_attrs["name"] for t in fs.time_front(study)]
    assert front == ["d", "b", "c"]
