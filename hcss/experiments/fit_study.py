"""Calibration to the study's published tables: `hcss simulate calibrate --to study`.

Fits, jointly for M1 and M2 (they share every value), the quantities the
paper does not state to its simulation tables in full, under the study's own
unit (`study_units`: means, SDs and medians of both tables per model and
split, and the units per split, 38 numbers):

- readings (categorical): discovery (`spatial` or `per_agent`), abandonment
  (`per_visit` or `rate`), g with or without v inside M2's discovery delay,
  the easy layout's other sites (anywhere or strictly farther), the label
  (best nearest or best not the furthest) and its distances (exact or ring);
- values (continuous): r_msg, the sensing radius, d_max between the sites'
  350 m and R = 500 m, the scale of α, the walk's turning sd, the scale of
  M2's discovery wait;
- (issue 39) where M_i applies: the uses of an F_I agent's messages that
  carry it (any non-empty set of queue, recruitment, inhibition), whether
  M1's queue messages carry it too, and d_min (search space or nearest site).

Everything else stays at the `literal` preset's values. The `modulation`
space (`Settings.space`) searches only M_i's readings with the values they
interact with, r_msg (shared by M1, M2 and M3), d_max and F_D's wait, the rest
at the default preset's values. The search is
optuna's TPE sampler (seeded) over the reduced experiment (28 scenarios × a
few runs); its trials are stored in an SQLite file in the output directory,
so an interrupted calibration resumes where it stopped. The best few
("finalists") are then run on the full experiment (28 × 10), and the one with
the smallest loss there is the fit. The output also holds the Pareto front of
M1's easy success against M2's easy success (the study has M1 weak and M2
strong on easy decisions), and PED-ANOVA importances of each searched value
(optuna's implementation): which parameters matter.

The search's scenarios use the experiment's default seed block; validate the
fit on another (`hcss simulate fidelity --preset study-calibrated --seed ...`).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hcss import study_units as su
from hcss.experiments import experiment as exp
from hcss.experiments import study_targets as st
from hcss.simulation.params import (
    ABANDONMENT_READINGS,
    DIFFICULTY_LABELS,
    DISCOVERY_READINGS,
    EASY_LAYOUT_OTHERS,
    G_READINGS,
    LABEL_DISTANCES,
    M1_QUEUE_MODULATION,
    M2_D_MIN,
    MODULATION_USES,
    Params,
)
from hcss.tablespec import CALIBRATION_TRIALS
from hcss.tidy_csv import write_rows

STUDY_NAME = "hcss-study-calibration"
SEARCH_SEED_BLOCK = 20_150_000  # the experiment's default scenarios (exp.experiment_scenarios)
MODELS = ("M1", "M2")

# The non-empty sets of M_i's uses, each '+'-joined (optuna's choices are plain strings).
USES_CHOICES: tuple[str, ...] = tuple(
    "+".join(u for i, u in enumerate(MODULATION_USES) if mask >> i & 1) for mask in range(1, 8)
)
# M_i's readings (issue 39), in every space.
MODULATION_SPACE: dict[str, tuple[Any, ...]] = {
    "m2_modulation_uses": ("categorical", USES_CHOICES),
    "m1_queue_modulation": ("categorical", M1_QUEUE_MODULATION),
    "m2_d_min": ("categorical", M2_D_MIN),
}

# name -> ("categorical", choices) or ("float", low, high, log scale)
SEARCH_SPACE: dict[str, tuple[Any, ...]] = {
    "discovery": ("categorical", DISCOVERY_READINGS),
    "abandonment": ("categorical", ABANDONMENT_READINGS),
    "m2_g_reading": ("categorical", G_READINGS),
    "message_rate": ("float", 1.0, 3.5, True),
    "sensing_radius_m": ("float", 2.0, 10.0, False),
    "fitted_d_max_m": ("float", 350.0, 500.0, False),
    "abandon_scale": ("float", 0.1, 4.0, True),
    "turn_sd_rad": ("float", 0.2, 1.0, False),
    "easy_layout_others": ("categorical", EASY_LAYOUT_OTHERS),
    "difficulty_label": ("categorical", DIFFICULTY_LABELS),
    "label_distances": ("categorical", LABEL_DISTANCES),
    "m2_discovery_wait_scale": ("float", 0.05, 1.0, True),
    **MODULATION_SPACE,
}
# The searches `calibrate --to study` offers (`--space`): everything, or M_i's readings
# with r_msg, d_max and F_D's wait, the rest at the default preset's values.
SPACES: dict[str, dict[str, tuple[Any, ...]]] = {
    "full": SEARCH_SPACE,
    "modulation": {
        **MODULATION_SPACE,
        **{
            name: SEARCH_SPACE[name]
            for name in ("message_rate", "fitted_d_max_m", "m2_discovery_wait_scale")
        },
    },
}


@dataclass(frozen=True)
class Settings:
    """What a calibration run does; stored beside its trials so a resume cannot mix two."""

    budget: int = 150  # search trials (reduced experiment each)
    scenarios: int = 28
    # per scenario and model in the search; a unit's value is a mean over runs, so its
    # SD and median need the study's 10 (fewer scenarios keep the search cheaper)
    runs: int = su.STUDY_RUNS
    finalists: int = 3
    final_runs: int = 10  # per scenario and model for the finalists (the full experiment)
    seed: int = 1  # the sampler's seed
    scenario_seed: int = SEARCH_SEED_BLOCK
    space: str = "full"  # a key of SPACES

    @property
    def search_space(self) -> dict[str, tuple[Any, ...]]:
        return SPACES[self.space]


@dataclass(frozen=True)
class Evaluation:
    """One parameter set run on one experiment: its cells, loss and the Pareto quantities."""

    values: dict[str, Any]
    measured: dict[tuple[str, str], st.Measured]  # per decision, for reference
    units: dict[tuple[str, str, str], su.Summary]  # under the study's unit: what is fitted
    scenarios: int
    loss: float
    met: int  # of the 38 fitted published numbers
    m1_easy_success: float  # mean over units with an easy decision, %
    m2_easy_success: float
    m2_time_cost: float  # M2's overall mean decision time minus M1's, minutes
    m2_easy_time: float  # mean over units with an easy decision, min
    m2_difficult_success: float  # mean over units with a difficult decision, %


def base_params(space: str = "full") -> Params:
    """The values the calibration does not search: the literal preset's with d_max fitted
    (the full space), or the default preset's (the modulation space)."""
    from hcss.simulation.presets import DEFAULT_PRESET, preset_params

    if space == "modulation":
        return preset_params(DEFAULT_PRESET).with_changes(m2_distance_bounds="fitted")
    return preset_params("literal").with_changes(m2_distance_bounds="fitted")


def params_for(values: dict[str, Any], space: str = "full") -> Params:
    """The shared params of one point of the search ('+'-joined uses become their set)."""
    changes = dict(values)
    if isinstance(changes.get("m2_modulation_uses"), str):
        changes["m2_modulation_uses"] = tuple(changes["m2_modulation_uses"].split("+"))
    return base_params(space).with_changes(**changes)


def evaluate(
    values: dict[str, Any],
    scenarios: int,
    runs: int,
    scenario_seed: int,
    workers: int,
    dask_address: str | None = None,
    space: str = "full",
) -> Evaluation:
    """Run M1 and M2 on one experiment and measure its distance from the study's tables."""
    params = params_for(values, space)
    jobs = exp.jobs_for(exp.experiment_scenarios(scenarios, scenario_seed, params), MODELS, runs)
    rows = exp.run_jobs(jobs, workers, dask_address, params=params)
    return evaluation_of(values, rows, scenarios)


def evaluation_of(values: dict[str, Any], rows: list[dict[str, Any]], scenarios: int) -> Evaluation:
    """The distance of an experiment's decisions from the study's tables, under its unit."""
    units = su.summarise(su.units(rows))

    def mean(model: str, split: str, measure: str = "success_pct") -> float:
        cell = units.get((model, split, measure))
        return cell.mean if cell else math.nan

    return Evaluation(
        values=dict(values),
        measured=st.measure(rows),
        units=units,
        scenarios=scenarios,
        loss=su.loss(units, scenarios),
        met=su.numbers_met(units, scenarios),
        m1_easy_success=mean("M1", "easy"),
        m2_easy_success=mean("M2", "easy"),
        m2_time_cost=st.overall_time(rows, "M2") - st.overall_time(rows, "M1"),
        m2_easy_time=mean("M2", "easy", "time_min"),
        m2_difficult_success=mean("M2", "difficult"),
    )


def suggest(trial: Any, space: dict[str, tuple[Any, ...]] = SEARCH_SPACE) -> dict[str, Any]:
    """One point of the search space, drawn by the optuna trial."""
    values: dict[str, Any] = {}
    for name, spec in space.items():
        if spec[0] == "categorical":
            values[name] = trial.suggest_categorical(name, list(spec[1]))
        else:
            values[name] = trial.suggest_float(name, spec[1], spec[2], log=spec[3])
    return values


def _record(trial: Any, evaluation: Evaluation) -> None:
    trial.set_user_attr("met", evaluation.met)
    trial.set_user_attr("m1_easy_success", evaluation.m1_easy_success)
    trial.set_user_attr("m2_easy_success", evaluation.m2_easy_success)
    trial.set_user_attr("m2_time_cost", evaluation.m2_time_cost)
    trial.set_user_attr("m2_easy_time", evaluation.m2_easy_time)
    trial.set_user_attr("m2_difficult_success", evaluation.m2_difficult_success)
    for (model, split), m in evaluation.measured.items():
        trial.set_user_attr(f"{model}_{split}_success", m.success_pct)
        trial.set_user_attr(f"{model}_{split}_time", m.time_min)


def resumable_study(
    out: Path,
    name: str,
    wanted: dict[str, Any],
    seed: int,
    starting: Callable[[], Iterable[dict[str, Any]]],
    mismatch: str,
) -> Any:
    """An optuna study in OUT/calibration.db, created or resumed, for both calibrations.

    `wanted` (OUT/calibration.json) is what makes trials comparable: a resume with
    another raises ValueError(`mismatch`). A new study starts from `starting()`.
    """
    import optuna

    out.mkdir(parents=True, exist_ok=True)
    manifest = out / "calibration.json"
    if manifest.exists():
        if json.loads(manifest.read_text(encoding="utf-8")) != wanted:
            raise ValueError(mismatch)
    else:
        manifest.write_text(json.dumps(wanted, indent=2), encoding="utf-8")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(
        study_name=name,
        storage=f"sqlite:///{out / 'calibration.db'}",
        sampler=optuna.samplers.TPESampler(seed=seed),
        direction="minimize",
        load_if_exists=True,
    )
    if not study.trials:
        for values in starting():
            study.enqueue_trial(values)
    return study


def open_study(out: Path, settings: Settings) -> Any:
    """The model's calibration study, created or resumed.

    A resume must search the same experiment (scenarios, runs, seeds, space);
    a larger budget continues the search, more finalists rerun the best.
    """
    # What makes trials comparable; the budget and the finalists may change on resume.
    wanted: dict[str, Any] = {
        "scenarios": settings.scenarios,
        "runs": settings.runs,
        "sampler_seed": settings.seed,
        "scenario_seed": settings.scenario_seed,
        "search_space": _jsonable(settings.search_space),
    }
    if settings.space == "modulation":  # its unsearched values are the default preset's
        from hcss.simulation.presets import DEFAULT_PRESET

        wanted["base_preset"] = DEFAULT_PRESET
    return resumable_study(
        out,
        STUDY_NAME,
        wanted,
        settings.seed,
        lambda: starting_points(settings.space),
        f"{out} holds a calibration of another experiment or search space; choose "
        "another --out, or repeat the first run's --scenarios, --runs and seeds",
    )


def _searched_values(params: Params, space: dict[str, tuple[Any, ...]]) -> dict[str, Any]:
    values = {name: getattr(params, name) for name in space}
    values["fitted_d_max_m"] = params.m2_d_max_m
    if "m2_modulation_uses" in values:
        values["m2_modulation_uses"] = "+".join(params.m2_modulation_uses)
    return values


def starting_points(space: str = "full") -> list[dict[str, Any]]:
    """The search's first trials; a small budget then starts from what is known and TPE
    takes over after them.

    Full space: the presets' values, each under both labels. Modulation space: the
    default preset, then M_i where Eq. 4 prints it (recruitment and inhibition) and on
    recruitment alone, each with M1's queue unmodulated and modulated.
    """
    from hcss.simulation.presets import DEFAULT_PRESET, PRESETS

    if space == "modulation":
        default = _searched_values(PRESETS[DEFAULT_PRESET], SPACES[space])
        return [default] + [
            default | {"m2_modulation_uses": uses, "m1_queue_modulation": queue}
            for uses in ("recruitment+inhibition", "recruitment")
            for queue in M1_QUEUE_MODULATION
        ]
    points = []
    for params in PRESETS.values():
        values = _searched_values(params, SEARCH_SPACE)
        for label in DIFFICULTY_LABELS:
            points.append(
                values
                | {"difficulty_label": label}
                | (
                    {"easy_layout_others": "strictly_farther", "label_distances": "ring"}
                    if label == "best_not_furthest"
                    else {}
                )
            )
    return points


def _jsonable(space: dict[str, tuple[Any, ...]]) -> dict[str, list[Any]]:
    return {k: [list(x) if isinstance(x, tuple) else x for x in v] for k, v in space.items()}


def search(
    study: Any,
    settings: Settings,
    workers: int,
    dask_address: str | None = None,
    on_trial: Callable[[int, Evaluation], None] | None = None,
) -> None:
    """Run search trials until the study holds `settings.budget` completed ones."""
    import optuna

    done = sum(t.state == optuna.trial.TrialState.COMPLETE for t in study.trials)
    for _ in range(max(0, settings.budget - done)):
        trial = study.ask()
        evaluation = evaluate(
            suggest(trial, settings.search_space),
            settings.scenarios,
            settings.runs,
            settings.scenario_seed,
            workers,
            dask_address,
            settings.space,
        )
        _record(trial, evaluation)
        study.tell(trial, evaluation.loss)
        if on_trial is not None:
            on_trial(trial.number, evaluation)


def completed(study: Any) -> list[Any]:
    import optuna

    return [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]


def finalists(study: Any, settings: Settings) -> list[dict[str, Any]]:
    """The parameter sets of the best search trials, best first."""
    best = sorted(completed(study), key=lambda t: t.value)[: settings.finalists]
    return [dict(t.params) for t in best]


def pareto_front(
    study: Any, down: str = "m1_easy_success", up: str = "m2_easy_success"
) -> list[Any]:
    """Search trials not dominated in (`down` ↓, `up` ↑), sorted by `down`.

    The default front is M1's easy success against M2's: the study has M1 weak
    (70.5%) and M2 strong (76.7%) on easy decisions; a trial on the front at or
    beyond that point would meet both. `time_front` is the other trade. Success
    is the mean over units with an easy (difficult) decision.
    """
    points = [
        t
        for t in completed(study)
        if math.isfinite(t.user_attrs.get(down, math.nan))
        and math.isfinite(t.user_attrs.get(up, math.nan))
    ]

    def dominated(t: Any) -> bool:
        low, high = t.user_attrs[down], t.user_attrs[up]
        return any(
            o.user_attrs[down] <= low
            and o.user_attrs[up] >= high
            and (o.user_attrs[down] < low or o.user_attrs[up] > high)
            for o in points
        )

    return sorted((t for t in points if not dominated(t)), key=lambda t: t.user_attrs[down])


def time_front(study: Any) -> list[Any]:
    """Search trials not dominated in (M2's easy time ↓, M2's difficult success ↑).

    The study's M2 is right on 64.0% of difficult units at 4.17 min on easy ones;
    in this family the time M2 spends on easy decisions buys its value
    discrimination on difficult ones (docs/simulation-notes.md), and this front
    shows how much of each a reading gives up for the other.
    """
    return pareto_front(study, down="m2_easy_time", up="m2_difficult_success")


def importances(study: Any) -> dict[str, float]:
    """PED-ANOVA importance of each searched value for the loss (needs a few trials).

    How far each value's distribution among the best trials departs from its
    distribution over all trials (optuna's implementation, no model fitted).
    """
    import optuna

    if len(completed(study)) < 4:
        return {}
    evaluator = optuna.importance.PedAnovaImportanceEvaluator()
    return dict(optuna.importance.get_param_importances(study, evaluator=evaluator))


@dataclass(frozen=True)
class Calibration:
    """The outcome: every finalist's full-experiment evaluation, the fit, and the wall time."""

    finals: list[Evaluation]
    fit: Evaluation
    front: list[Any]
    time_front: list[Any]
    importance: dict[str, float]
    trials: int
    wall_s: float


def calibrate(
    out: Path,
    settings: Settings,
    workers: int = 2,
    dask_address: str | None = None,
    on_trial: Callable[[int, Evaluation], None] | None = None,
    on_finalist: Callable[[Evaluation], None] | None = None,
) -> Calibration:
    """Search, run the finalists on the full experiment, and write OUT's files."""
    started = time.perf_counter()
    study = open_study(out, settings)
    search(study, settings, workers, dask_address, on_trial)
    finals = []
    for values in finalists(study, settings):
        evaluation = evaluate(
            values,
            settings.scenarios,
            settings.final_runs,
            settings.scenario_seed,
            workers,
            dask_address,
            settings.space,
        )
        finals.append(evaluation)
        if on_finalist is not None:
            on_finalist(evaluation)
    fit = min(finals, key=lambda e: e.loss)
    result = Calibration(
        finals=finals,
        fit=fit,
        front=pareto_front(study),
        time_front=time_front(study),
        importance=importances(study),
        trials=len(completed(study)),
        wall_s=time.perf_counter() - started,
    )
    write_trials(study, out / "trials.csv", settings.search_space)
    (out / "fit.json").write_text(json.dumps(fit.values, indent=2), encoding="utf-8")
    (out / "report.md").write_text(report(result, settings), encoding="utf-8")
    return result


def write_trials(study: Any, path: Path, space: dict[str, tuple[Any, ...]] = SEARCH_SPACE) -> None:
    """Every search trial: its values, loss, cells met and measured cells
    (hcss.tablespec.CALIBRATION_TRIALS), by the one CSV writer."""
    trials = completed(study)
    attrs = sorted({k for t in trials for k in t.user_attrs})
    write_rows(
        path,
        CALIBRATION_TRIALS.expand(parameter=list(space), measure=attrs),
        (
            {
                "trial": t.number,
                **{name: t.params.get(name) for name in space},
                "loss": t.value,
                **{name: t.user_attrs.get(name) for name in attrs},
            }
            for t in trials
        ),
    )


def _values_line(values: dict[str, Any]) -> str:
    return ", ".join(
        f"{k} = {v:.3g}" if isinstance(v, float) else f"{k} = {v}" for k, v in values.items()
    )


def report(result: Calibration, settings: Settings) -> str:
    """The calibration's outcome as Markdown."""
    fit = result.fit
    space = settings.search_space
    n_numbers = len(su.distances(fit.units))
    lines = [
        "# Calibration to the study's published tables",
        "",
        f"Search: {result.trials} trials of the reduced experiment ({settings.scenarios} "
        f"scenarios × {settings.runs} run(s) × M1, M2; scenario seeds from "
        f"{settings.scenario_seed}); finalists: the best {settings.finalists} on "
        f"{settings.scenarios} × {settings.final_runs}. Search space {settings.space!r}; "
        f"free values fitted: {len(space)} "
        f"({sum(s[0] == 'categorical' for s in space.values())} "
        f"readings, {sum(s[0] == 'float' for s in space.values())} continuous) against "
        f"{n_numbers} published numbers under the study's unit (means, SDs and medians of "
        f"both tables, units per split). Wall time of this invocation (a resumed search "
        f"counts only its own trials) {result.wall_s / 60:.1f} min.",
        "",
        "## The fit",
        "",
        _values_line(fit.values),
        "",
        f"Loss {fit.loss:.2f} (squared distance in bands: 10 points of success, 1 min of "
        f"time, 30 units); {fit.met} of {n_numbers} published numbers within their band; "
        f"M2's time cost {fit.m2_time_cost:+.2f} min.",
        "",
        su.comparison_markdown(fit.units, fit.scenarios),
        "",
        "Per decision (for reference; not fitted):",
        "",
        st.comparison_table(fit.measured),
        "",
        "## Finalists on the full experiment",
        "",
        "| loss | within band | M1 easy SR % | M2 easy SR % | M2 − M1 time (min) | values |",
        "|---|---|---|---|---|---|",
    ]
    for e in result.finals:
        lines.append(
            f"| {e.loss:.2f} | {e.met} | {e.m1_easy_success:.1f} | {e.m2_easy_success:.1f} "
            f"| {e.m2_time_cost:+.2f} | {_values_line(e.values)} |"
        )
    lines += [
        "",
        "## Pareto front of the search: M1's easy success against M2's easy success",
        "",
        "Per unit with an easy decision; the study: M1 70.49, M2 76.7. A point with M1 at "
        "or below 70.49 and M2 at or above 76.7 would meet both.",
        "",
        "| M1 easy SR % | M2 easy SR % | M2 − M1 time (min) | loss | within band | values |",
        "|---|---|---|---|---|---|",
    ]
    for t in result.front:
        lines.append(
            f"| {t.user_attrs['m1_easy_success']:.1f} | {t.user_attrs['m2_easy_success']:.1f} "
            f"| {t.user_attrs['m2_time_cost']:+.2f} | {t.value:.2f} | {t.user_attrs['met']} "
            f"| {_values_line(dict(t.params))} |"
        )
    lines += [
        "",
        "## Pareto front of the search: M2's easy time against M2's difficult success",
        "",
        "Per unit; the study: M2 easy 4.17 min, difficult 64.04%. A point at or below "
        "4.17 min with 64.04% or more would meet both.",
        "",
        "| M2 easy DT (min) | M2 difficult SR % | M2 easy SR % | loss | within band | values |",
        "|---|---|---|---|---|---|",
    ]
    for t in result.time_front:
        lines.append(
            f"| {t.user_attrs['m2_easy_time']:.2f} | {t.user_attrs['m2_difficult_success']:.1f} "
            f"| {t.user_attrs['m2_easy_success']:.1f} | {t.value:.2f} | {t.user_attrs['met']} "
            f"| {_values_line(dict(t.params))} |"
        )
    lines += ["", "## Which values matter (PED-ANOVA importance for the loss)", ""]
    if result.importance:
        lines += ["| value | importance |", "|---|---|"]
        lines += [f"| {k} | {v:.3f} |" for k, v in result.importance.items()]
    else:
        lines.append("Too few trials to estimate importances.")
    return "\n".join(lines) + "\n"
