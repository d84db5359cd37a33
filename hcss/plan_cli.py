"""`hcss plan`: a study's predicted results and power before anyone is recruited.

It reads the study file (its models, counterbalancing cells, trial length and
preset), so it sits beside the command line rather than in the experiments,
which never import the platform; the work is `hcss.experiments.plan`.
"""

from __future__ import annotations

from pathlib import Path

import click
from tqdm import tqdm


def _ns(text: str) -> tuple[int, ...]:
    try:
        ns = tuple(sorted({int(part) for part in text.split(",") if part.strip()}))
    except ValueError:
        raise click.BadParameter(f"comma-separated whole numbers, not {text!r}") from None
    if not ns or min(ns) < 3:
        raise click.BadParameter("each N must be at least 3")
    return ns


def model_for(population_path: Path, study_preset: str) -> tuple[str, str]:
    """The preset the plan's model runs under, and the population in the plan's words.

    A population fitted by `hcss simulate calibrate --to study-teams` reproduces the
    human tables under the preset it was fitted on (population.json records it), so
    the plan runs that preset, whatever the study file names for its live trials; a
    population without a recorded preset runs under the study file's.
    """
    import json

    recorded = json.loads(population_path.read_text(encoding="utf-8")).get("preset")
    if recorded is None:
        return (
            study_preset,
            f"{population_path} (no preset recorded: the study file's {study_preset})",
        )
    note = (
        ""
        if recorded == study_preset
        else f"; the study file names {study_preset} for its live trials"
    )
    return recorded, f"{population_path} (fitted on preset {recorded}, which the plan runs{note})"


@click.command("plan")
@click.option("--study", default="original", show_default=True, help="Study file name.")
@click.option("--n", "ns", default="12,20,28,40,60", show_default=True, help="Ns of the curve.")
@click.option("--replications", type=click.IntRange(min=10), default=500, show_default=True)
@click.option(
    "--pool",
    "pool_participants",
    type=click.IntRange(min=8),
    default=120,
    show_default=True,
    help="Synthetic participants simulated once and resampled.",
)
@click.option(
    "--pool-scenarios",
    type=click.IntRange(min=4),
    default=120,
    show_default=True,
    help="Simulation-only scenarios simulated once and resampled.",
)
@click.option(
    "--runs",
    "scenario_runs",
    type=click.IntRange(min=1),
    default=3,
    show_default=True,
    help="Runs per simulation-only scenario and model (a unit is their mean; the study: 10).",
)
@click.option(
    "--population",
    "population_path",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="population.json from `hcss simulate calibrate --to study-teams` "
    "(default: the population fitted to the study's human teams, shipped with hcss). "
    "The plan runs the preset it was fitted on.",
)
@click.option("--seed", type=int, default=1, show_default=True)
@click.option("--workers", type=click.IntRange(min=1), default=2, show_default=True)
@click.option("--dask", "dask_address", default=None, help="Dask scheduler address, or 'local'.")
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/plan"),
    show_default=True,
)
def plan_command(
    study: str,
    ns: str,
    replications: int,
    pool_participants: int,
    pool_scenarios: int,
    scenario_runs: int,
    population_path: Path | None,
    seed: int,
    workers: int,
    dask_address: str | None,
    out: Path,
) -> None:
    """Simulate the study with synthetic participants and estimate each test's power.

    N synthetic participants go through the study file's protocol and
    counterbalancing; the pool's export is analysed by `hcss analyze`, and
    the power of each test (Kruskal-Wallis across the five groups,
    Tukey-Kramer and Mann-Whitney pairs; success and decision time; overall,
    easy, difficult) is estimated for each N by resampling the pool. Writes
    OUT/plan.html (tables, power curves, the N for 80%, every assumption).
    """
    from hcss.experiments import plan as planning
    from hcss.experiments.operators_fit import FITTED_POPULATION, load_population
    from hcss.platform.study.studyfile import StudyFileError, load_study
    from hcss.simulation.presets import preset_params

    try:
        study_file = load_study(study)
    except StudyFileError as error:
        raise click.BadParameter(str(error), param_hint="--study") from error
    cells = tuple(
        tuple((model, cell.first_sections.get(model, "easy")) for model in cell.model_order)
        for cell in study_file.cells
    )
    population_path = population_path or FITTED_POPULATION
    try:
        population = load_population(population_path)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--population") from error
    preset, described = model_for(population_path, study_file.simulation.preset)
    settings = planning.PlanSettings(
        study=study,
        cells=cells,
        trial_s=float(study_file.timing.trial_s),
        ns=_ns(ns),
        replications=replications,
        pool_participants=pool_participants,
        pool_scenarios=pool_scenarios,
        scenario_runs=scenario_runs,
        seed=seed,
        population=described,
    )
    params = preset_params(preset)
    bar = tqdm(total=3, unit="step", desc="hcss plan")

    def step(message: str) -> None:
        bar.set_postfix_str(message)
        bar.update(1)

    result = planning.run_plan(out, settings, population, params, workers, dask_address, step)
    bar.close()
    click.echo(planning.summary(result))
    click.echo(f"Wrote {out / 'plan.html'} in {result.timings['total'] / 60:.1f} min.")
