"""`hcss simulate calibrate --to study-teams`: the synthetic operator population fitted to §11.

Fits the population's median traits and its spread (`Population`) jointly
over M1, M2 and M3 and both difficulties, on the default preset
(`presets.DEFAULT_PRESET`, read at run time: a new default is re-fitted by
running the command again), to the means of §11's cells within their bands
(`study_teams`). The search is optuna's seeded TPE sampler, as the model's
calibration (`fit_study`); its trials are kept in an SQLite file in the
output directory, so an interrupted calibration resumes.

Scenario blocks: the search runs participants (and their scenarios) seeded
from `FIT_BLOCK`. Its best few trials (`Settings.finalists`) are judged again
on `SELECTION_BLOCK` with more participants, and the best there is the fit: a
search of 16 participants a trial rewards its own block's noise (a search
continued from 300 to 450 trials lowered its loss from 81 to 74 and raised
both held-out losses, from 77 and 88 to 100 and 95). The fit is then judged on
`VALIDATION_BLOCKS`, which neither the search nor the selection saw. The
study's tests on the human data are not read.
"""

from __future__ import annotations

import contextlib
import json
import math
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from hcss.experiments import study_claims
from hcss.experiments import study_teams as teams
from hcss.experiments.synthetic_teams import participants, pooled, run_participants
from hcss.simulation.params import Params
from hcss.simulation.synthetic import Population, Traits

STUDY_NAME = "hcss-study-teams-calibration"
#: The population fitted to §11 on the default preset, shipped with hcss (`hcss plan`'s default):
#: the population.json of `hcss simulate calibrate --to study-teams`, as written.
FITTED_POPULATION = Path(__file__).parent / "study-teams-population.json"
FIT_BLOCK = 30_000_000
SELECTION_BLOCK = 31_000_000
VALIDATION_BLOCKS = (40_000_000, 41_000_000)
STARTS_MAX_BYTES = 1 << 20  # a --start file: a few persons of 25 values each

# trait -> (low, high, log scale); "spread" is the population's
SEARCH_SPACE: dict[str, tuple[float, float, bool]] = {
    "glance_interval_s": (1.0, 10.0, True),
    "stay_prob": (0.01, 0.9, True),
    "reaction_time_s": (1.0, 8.0, True),
    "value_noise": (0.003, 0.2, True),
    "value_resolution": (0.005, 0.15, True),
    "investigate_prob": (0.02, 1.0, True),
    "stalled_investigate_prob": (0.05, 1.0, True),
    "stall_window_s": (5.0, 120.0, True),
    "survey_s": (1.0, 240.0, True),
    "investigate_burst": (1.0, 8.0, True),
    "decide_support": (0.30, 0.6, False),
    "decide_prob": (0.02, 1.0, True),
    "hasten_prob": (0.005, 1.0, True),
    "abandon_support": (0.05, 0.4, False),
    "abandon_gap": (0.02, 0.3, False),
    "abandon_prob": (0.01, 1.0, True),
    "redirect_prob": (0.005, 1.0, True),
    "slip_prob": (0.001, 0.2, True),
    "observe_collective_prob": (0.005, 1.0, True),
    "observe_target_prob": (0.001, 0.5, True),
    "observe_change_prob": (0.005, 1.0, True),
    "push_margin": (0.0, 0.15, False),
    "perception_lapse": (0.01, 0.5, True),
    "comprehension_lapse": (0.01, 0.5, True),
    "projection_lapse": (0.01, 0.5, True),
    "spread": (0.05, 1.0, True),
}


@dataclass(frozen=True)
class Settings:
    budget: int = 60  # search trials
    participants: int = 16  # per search trial (each runs M1, M2 and M3)
    validation_participants: int = teams.STUDY_PARTICIPANTS  # per validation block
    finalists: int = 8  # the search's best trials judged again on the selection block
    selection_participants: int = 56  # twice the study's: a finalist's loss with less noise
    seed: int = 1  # the sampler's
    fit_block: int = FIT_BLOCK
    # the persons the search starts from after the default one (`load_starts`); none: the
    # shipped fit
    starts: tuple[dict[str, float], ...] = ()


@dataclass(frozen=True)
class Evaluation:
    population: Population
    measured: dict[tuple[str, str, str], teams.Measured]
    loss: float
    met: int
    block: int
    participants: int
    # per cell, how its mean clusters by participant on this block (`teams.design_effects`;
    # measured for the held-out blocks only)
    effects: dict[tuple[str, str, str], float] = field(default_factory=dict)


def default_params() -> Params:
    """The default preset's params, read now (another helper may change the default)."""
    from hcss.simulation.presets import preset_params

    return preset_params()


def population_of(values: dict[str, float]) -> Population:
    traits = {k: v for k, v in values.items() if k != "spread"}
    return Population(Traits(**(asdict(Traits()) | traits)), values.get("spread", 0.3))


def evaluate(
    population: Population,
    n: int,
    block: int,
    workers: int = 1,
    dask_address: str | None = None,
    params: Params | None = None,
    with_effects: bool = False,
) -> Evaluation:
    """Run n synthetic participants of block `block` and measure §11's cells on them (and,
    `with_effects`, their design effects: only the held-out blocks' report prints them)."""
    people = participants(n, block)
    rows = pooled(
        run_participants(people, population, params or default_params(), workers, dask_address)
    )
    by_trial = teams.values_by_trial(rows.decisions, rows.requests, rows.observations, rows.probes)
    measured = teams.summarise(by_trial)
    return Evaluation(
        population,
        measured,
        teams.loss(measured),
        len(teams.STUDY_TEAMS) - len(teams.misses(measured)),
        block,
        n,
        teams.design_effects(by_trial) if with_effects else {},
    )


def open_study(out: Path, settings: Settings) -> Any:
    """The optuna study in OUT/calibration.db, created or resumed (same experiment only).

    A new search starts from the default person and then from `settings.starts` when
    given (`--start`, which a resume must repeat), else from the last fit when hcss ships
    one this operator can use.
    """
    from hcss.experiments.fit_study import resumable_study  # the model's calibration's, shared

    wanted = {
        "participants": settings.participants,
        "sampler_seed": settings.seed,
        "fit_block": settings.fit_block,
        "search_space": {k: list(v) for k, v in SEARCH_SPACE.items()},
        "preset": default_params().preset,
    }
    if settings.starts:  # only then: a search begun without --start resumes as before
        wanted["starts"] = [dict(point) for point in settings.starts]

    def starting() -> list[dict[str, float]]:
        points = [_within_space(Population())]
        if settings.starts:
            return points + [dict(point) for point in settings.starts]
        # none shipped, or one fitted for an older operator: this search replaces it
        with contextlib.suppress(ValueError):
            points.append(_within_space(load_population(FITTED_POPULATION)))
        return points

    return resumable_study(
        out,
        STUDY_NAME,
        wanted,
        settings.seed,
        starting,
        f"{out} holds a calibration of another experiment, preset, search space or "
        "starting persons; "
        "choose another --out",
    )


def _within_space(population: Population) -> dict[str, float]:
    """A population's traits as search values, each clipped into its search range."""
    values = population.median.to_dict() | {"spread": population.spread}
    return {
        name: min(max(float(values[name]), low), high)
        for name, (low, high, _log) in SEARCH_SPACE.items()
    }


def load_starts(path: Path) -> tuple[dict[str, float], ...]:
    """A search's starting persons from a JSON file, or ValueError saying what is wrong.

    The file is a list of objects, one per person, each naming search values (the
    traits of `SEARCH_SPACE` and "spread") inside their search ranges; a name not given
    takes the shipped fit's value (the default person's when hcss ships none this
    operator can use). Naming every value makes a search reproducible whatever is
    shipped: the shipped fit's own search is started this way
    (docs/synthetic-operators.md).
    """
    if not path.is_file():  # a device or a pipe could be read for ever
        raise ValueError(f"{path} is not a regular file")
    if path.stat().st_size > STARTS_MAX_BYTES:
        raise ValueError(f"{path} is larger than 1 MiB: not a list of persons")
    try:
        points = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{path} is not a readable JSON file ({error})") from error
    except RecursionError:
        raise ValueError(f"{path} is nested too deeply to be a list of persons") from None
    if not isinstance(points, list) or not points:
        raise ValueError(f"{path} must hold a non-empty list of starting persons")
    try:
        base = _within_space(load_population(FITTED_POPULATION))
    except ValueError:
        base = _within_space(Population())
    starts = []
    for number, point in enumerate(points, start=1):
        where = f"{path}, person {number}"
        if not isinstance(point, dict) or not point:
            raise ValueError(f"{where}: not an object naming search values")
        unknown = sorted(set(point) - set(SEARCH_SPACE))
        if unknown:
            raise ValueError(f"{where}: not a search value: {', '.join(map(str, unknown))}")
        for name, value in point.items():
            low, high, _log = SEARCH_SPACE[name]
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"{where}: {name} must be a number, not {value!r}")
            if not (math.isfinite(value) and low <= value <= high):
                raise ValueError(
                    f"{where}: {name} {value} is outside its search range {low}-{high}"
                )
        starts.append(base | {name: float(value) for name, value in point.items()})
    return tuple(starts)


def completed(study: Any) -> list[Any]:
    """The search's completed trials (its queued starting points are still to run)."""
    import optuna

    return [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]


def trials_done(study: Any) -> int:
    return len(completed(study))


def search(
    study: Any,
    settings: Settings,
    workers: int,
    dask_address: str | None = None,
    on_trial: Callable[[Evaluation], None] | None = None,
) -> None:
    for _ in range(max(0, settings.budget - trials_done(study))):
        trial = study.ask()
        values = {
            name: trial.suggest_float(name, low, high, log=log)
            for name, (low, high, log) in SEARCH_SPACE.items()
        }
        evaluation = evaluate(
            population_of(values), settings.participants, settings.fit_block, workers, dask_address
        )
        trial.set_user_attr("met", evaluation.met)
        study.tell(trial, evaluation.loss)
        if on_trial is not None:
            on_trial(evaluation)


@dataclass(frozen=True)
class Finalist:
    """One of the search's best trials, judged again on the selection block."""

    trial: int
    search_loss: float
    selection_loss: float
    population: Population


@dataclass(frozen=True)
class Calibration:
    fit: Population
    search_loss: float
    validations: list[Evaluation]
    trials: int
    wall_s: float
    finalists: tuple[Finalist, ...] = ()

    @property
    def chosen(self) -> Finalist | None:
        return least_judged(self.finalists) if self.finalists else None


def least_judged(finalists: tuple[Finalist, ...]) -> Finalist:
    """The fit: the finalist with the least loss on the selection block."""
    return min(finalists, key=lambda f: f.selection_loss)


def select(
    study: Any, settings: Settings, workers: int, dask_address: str | None = None
) -> tuple[Finalist, ...]:
    """The search's `finalists` best trials and the persons it started from after the
    default one (the shipped fit, or `--start`'s), each judged on `SELECTION_BLOCK`.

    A started person is judged whatever its search loss, so a new search replaces the
    fit it started from only with one that does better on the selection block: a search
    of 32 participants a trial started from the shipped fit (search loss 78.7, selection
    loss 65.5) ranked its own trials first and would have shipped one scoring 70.0.
    """
    trials = completed(study)
    best = sorted(trials, key=lambda t: (float(t.value), t.number))[: max(1, settings.finalists)]
    # optuna marks a queued trial with its fixed params (its own Study reads them so)
    started = [t for t in trials if t.number > 0 and "fixed_params" in t.system_attrs]
    finalists = []
    ranked = {t.number for t in best}
    for t in best + [t for t in started if t.number not in ranked]:
        population = population_of(dict(t.params))
        judged = evaluate(
            population, settings.selection_participants, SELECTION_BLOCK, workers, dask_address
        )
        finalists.append(Finalist(t.number, float(t.value), judged.loss, population))
    return tuple(finalists)


def calibrate(
    out: Path,
    settings: Settings,
    workers: int = 2,
    dask_address: str | None = None,
    on_trial: Callable[[Evaluation], None] | None = None,
) -> Calibration:
    """Search, choose among its best on the selection block, judge the choice on the
    validation blocks, and write OUT's files."""

    started = time.perf_counter()
    study = open_study(out, settings)
    search(study, settings, workers, dask_address, on_trial)
    finalists = select(study, settings, workers, dask_address)
    chosen = least_judged(finalists)
    fit = chosen.population
    validations = [
        evaluate(
            fit, settings.validation_participants, block, workers, dask_address, with_effects=True
        )
        for block in VALIDATION_BLOCKS
    ]
    trials = trials_done(study)
    result = Calibration(
        fit, chosen.search_loss, validations, trials, time.perf_counter() - started, finalists
    )
    fitted = fit.to_dict() | {
        "preset": default_params().preset,
        "search_loss": chosen.search_loss,
        "selection_loss": chosen.selection_loss,
        "trial": chosen.trial,
    }
    (out / "population.json").write_text(json.dumps(fitted, indent=2), encoding="utf-8")
    (out / "report.md").write_text(report(result, settings), encoding="utf-8")
    return result


def report(result: Calibration, settings: Settings) -> str:
    lines = [
        "# Synthetic operators calibrated to the study's human teams (§11)",
        "",
        f"Preset {default_params().preset}; search: {result.trials} trials of "
        f"{settings.participants} participants (× M1, M2, M3) from seed block "
        f"{settings.fit_block}, started from the default person and "
        + (
            f"{len(settings.starts)} given starting person(s)"
            if settings.starts
            else "the shipped fit (when this operator can use it)"
        )
        + f". Wall time of this invocation {result.wall_s / 60:.1f} min.",
        "",
        f"## The search's best {min(settings.finalists, len(result.finalists))} and the "
        f"persons it started from, judged again on block {SELECTION_BLOCK} "
        f"({settings.selection_participants} participants)",
        "",
        "| trial | search loss | selection loss | fit |",
        "|---|---|---|---|",
    ]
    chosen = result.chosen
    # `select` lists the search's best first, then the started persons not among them
    lines += [
        f"| {f.trial}{' (started)' if rank >= settings.finalists else ''} | "
        f"{f.search_loss:.2f} | {f.selection_loss:.2f} | {'yes' if f is chosen else ''} |"
        for rank, f in enumerate(result.finalists)
    ]
    lines += [
        "",
        "## Fitted population (median person, spread on each trait's natural scale)",
        "",
        "| trait | median |",
        "|---|---|",
    ]
    lines += [f"| {k} | {v:.3g} |" for k, v in result.fit.median.to_dict().items()]
    lines += [f"| spread | {result.fit.spread:.3g} |", ""]
    for e in result.validations:
        expected, every = teams.ceiling(e.participants)
        clustered, every_clustered = teams.ceiling(e.participants, e.effects)
        effects = [e.effects.get(cell.key, 1.0) for cell in teams.STUDY_TEAMS]
        lines += [
            f"## Held-out block {e.block}: {e.participants} participants; loss {e.loss:.2f}, "
            f"{e.met} of {len(teams.STUDY_TEAMS)} cells within band",
            "",
            f"A population whose people were the study's would meet {expected:.1f} cells on "
            f"such a block on average, and all {len(teams.STUDY_TEAMS)} with chance "
            f"{every:.2f}, from the study's and the block's sampling errors with values "
            f"independent; with decisions clustered by person as this block's are (design "
            f"effects {min(effects):.2f}-{max(effects):.2f}), {clustered:.1f} and "
            f"{every_clustered:.2f}.",
            "",
            teams.comparison_markdown(e.measured),
            "",
            "The study's words about its operators (held back from the fit; the first needs "
            "collectives alone, which `hcss plan` runs):",
            "",
            study_claims.claims_markdown(study_claims.claims(e.measured)),
            "",
            "Misses: "
            + (
                ", ".join(f"{c.measure} {c.model} {c.column}" for c in teams.misses(e.measured))
                or "none"
            ),
            "",
        ]
    return "\n".join(lines)


def load_population(path: Path) -> Population:
    """A fitted population from its population.json, or ValueError saying what is wrong.

    The file must name exactly this operator's traits: a population fitted before a
    trait was added or renamed meant something else, and is re-fitted rather than
    filled in with defaults.
    """
    try:
        values = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as error:
        raise ValueError(f"{path} is not a readable population.json ({error})") from error
    median = values.get("median") if isinstance(values, dict) else None
    if not isinstance(median, dict) or "spread" not in values:
        raise ValueError(f"{path} is not a population.json: it needs 'median' and 'spread'")
    known = set(asdict(Traits()))
    unknown, missing = set(median) - known, known - set(median)
    if unknown or missing:
        said = []
        if unknown:
            said.append(f"traits this operator does not know ({', '.join(sorted(unknown))})")
        if missing:
            said.append(f"none of its traits {', '.join(sorted(missing))}")
        raise ValueError(
            f"{path} has {' and '.join(said)}: it was fitted for another version of the "
            "operator; re-fit it with `hcss simulate calibrate --to study-teams`"
        )
    try:
        return Population.from_dict(values)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path} holds a trait this operator cannot use: {error}") from error
