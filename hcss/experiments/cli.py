"""`hcss simulate experiment|sweep|calibrate|fidelity|meanfield|structure`: the experiment commands.

They run batches of the model and, for `experiment`, ask the analysis for the
summary; the model's own command (`demo`) is in hcss.simulation.cli, and
hcss/cli.py lists both groups under the one `hcss simulate`.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click
from tqdm import tqdm

from hcss import study_units
from hcss.analysis.summary import summarise_decisions
from hcss.experiments import calibrate as cal
from hcss.experiments import experiment as exp
from hcss.experiments import fidelity as fid
from hcss.experiments import fit_study as fs
from hcss.experiments import study_targets
from hcss.simulation.cli import PRESET_OPTION
from hcss.simulation.operators import OPERATORS
from hcss.simulation.params import (
    ABANDONMENT_READINGS,
    DIFFICULTY_LABELS,
    DISCOVERY_READINGS,
    EASY_LAYOUT_OTHERS,
    FOREIGN_TARGETS,
    G_READINGS,
    LABEL_DISTANCES,
    M2_BEYOND_DMAX,
    M2_DISTANCE_BOUNDS,
    MODELS,
    Params,
)
from hcss.simulation.presets import DEFAULT_PRESET, PRESETS, preset_params

#: A click command function, before or after its options are attached.
F = TypeVar("F", bound=Callable[..., Any])


@click.group()
def simulate() -> None:
    """Experiment commands: batches of runs, sweeps, calibration and checks of the model."""


_WORKERS = click.option(
    "--workers",
    type=click.IntRange(min=1, max=64),
    default=2,
    show_default=True,
    help="Local processes.",
)


def _size_options(runs: int, runs_help: str, min_scenarios: int = 1) -> Callable[[F], F]:
    """--scenarios and --runs: how big a batch is (one definition for every batch command)."""

    def decorate(command: F) -> F:
        command = click.option(
            "--runs",
            type=click.IntRange(min=1, max=10_000),
            default=runs,
            show_default=True,
            help=runs_help,
        )(command)
        return click.option(
            "--scenarios",
            type=click.IntRange(min=min_scenarios, max=10_000),
            default=28,
            show_default=True,
        )(command)

    return decorate


def _batch_options(command: F) -> F:
    """--workers, --dask and --seed: where batch runs go and which scenarios they use."""
    for option in reversed(
        (
            _WORKERS,
            click.option(
                "--dask",
                "dask_address",
                default=None,
                help="Dask scheduler address, or 'local' for a LocalCluster.",
            ),
            click.option(
                "--seed",
                type=int,
                default=exp.DEFAULT_SCENARIO_SEED,
                show_default=True,
                help="Seed of the first scenario.",
            ),
        )
    ):
        command = option(command)
    return command


@simulate.command()
@PRESET_OPTION
@_size_options(runs=10, runs_help="Runs per scenario and model.")
@click.option(
    "--set",
    "changes",
    multiple=True,
    metavar="NAME=VALUE",
    help="Change one of the preset's values for this run (repeatable), e.g. "
    "--set m2_modulation_uses=recruitment+inhibition --set message_rate=2.25.",
)
@click.option(
    "--models",
    default=None,
    help="Comma-separated models [default: M1,M2; M1,M2,M3 with --operator].",
)
@_batch_options
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/simulation"),
    show_default=True,
)
@click.option(
    "--operator",
    type=click.Choice(OPERATORS),
    default=None,
    help="Run operated trials (human-team condition) with this scripted operator; "
    "--models then defaults to M1,M2,M3.",
)
def experiment(
    preset: str,
    scenarios: int,
    runs: int,
    models: str | None,
    workers: int,
    dask_address: str | None,
    seed: int,
    out: Path,
    operator: str | None,
    changes: tuple[str, ...],
) -> None:
    """The simulation-only experiment: scenarios × runs × models, no operator.

    With --operator NAME, the same trials with a scripted operator whose
    requests go through the request API: a pilot of the human-team
    conditions. Analyse those with `hcss analyze OUT --include-pilot --out REPORT`
    (simulated operators have no participants table).

    Writes OUT/decisions.csv, OUT/summary.md (and summary.csv/.tex, by hcss.analysis),
    and prints the summary.
    """
    if models is None:
        models = "M1,M2" if operator is None else "M1,M2,M3"
    chosen = [m.strip() for m in models.split(",") if m.strip()]
    unknown = [m for m in chosen if m not in MODELS]
    if unknown or not chosen:
        raise click.BadParameter(
            f"models must be among {', '.join(MODELS)}; got {models!r}", param_hint="--models"
        )
    try:
        params = preset_params(preset).with_changes(**exp.parse_changes(changes))
    except (ValueError, TypeError) as error:
        raise click.BadParameter(str(error), param_hint="--set") from None
    jobs = exp.jobs_for(exp.experiment_scenarios(scenarios, seed, params), chosen, runs, operator)
    where = f"Dask ({dask_address})" if dask_address else f"{workers} local process(es)"
    click.echo(
        f"{len(jobs)} runs ({scenarios} scenarios × {runs} runs × {', '.join(chosen)}) "
        f"on {where}, preset {preset}{' with ' + ', '.join(changes) if changes else ''}."
    )
    started = time.perf_counter()
    with tqdm(total=len(jobs), unit="run", desc="experiment", dynamic_ncols=True) as bar:
        rows = exp.run_jobs(jobs, workers, dask_address, on_done=bar.update, params=params)
    elapsed = time.perf_counter() - started
    out.mkdir(parents=True, exist_ok=True)
    exp.write_decisions(rows, out / "decisions.csv")
    table = summarise_decisions(out / "decisions.csv")
    (out / "summary.md").write_text(
        f"# {'Operated experiment: ' + operator if operator else 'Simulation-only experiment'}\n\n"
        f"{len(jobs)} runs, {len(rows)} decisions, {elapsed:.0f} s, preset {preset}"
        f"{' with ' + ', '.join(changes) if changes else ''}.\n\n"
        "Unit: the scenario (each run's success rate and mean decision time, averaged over "
        "the scenario's runs), as `hcss analyze` computes it.\n\n"
        f"{table}\n",
        encoding="utf-8",
    )
    click.echo(table)
    if operator is None and {"M1", "M2"} <= set(chosen):
        units = study_units.summarise(study_units.units(rows))
        click.echo(
            f"\nUnder the study's unit: loss {study_units.loss(units, scenarios):.1f} over its "
            f"38 numbers, {study_units.numbers_met(units, scenarios)} within band.\n"
        )
        click.echo(study_targets.shape_table(study_targets.decision_shape(rows)))
    click.echo(f"{len(rows)} decisions written to {out / 'decisions.csv'} in {elapsed:.0f} s.")


def _reading_options(command: F) -> F:
    """Options that override the readings of the paper (params.py) for one command."""
    for name, choices in reversed(
        (
            ("discovery", DISCOVERY_READINGS),
            ("m2-distance-bounds", M2_DISTANCE_BOUNDS),
            ("m2-beyond-dmax", M2_BEYOND_DMAX),
            ("foreign-targets", FOREIGN_TARGETS),
            ("abandonment", ABANDONMENT_READINGS),
            ("m2-g-reading", G_READINGS),
            ("easy-layout-others", EASY_LAYOUT_OTHERS),
            ("difficulty-label", DIFFICULTY_LABELS),
            ("label-distances", LABEL_DISTANCES),
        )
    ):
        command = click.option(
            f"--{name}",
            type=click.Choice(choices),
            default=None,
            help="Override this reading of the preset.",
        )(command)
    return PRESET_OPTION(command)


def _params_with(preset: str = DEFAULT_PRESET, **readings: Any) -> Params:
    """The preset's params with the readings given on the command line."""
    changes = {k: v for k, v in readings.items() if v is not None}
    return preset_params(preset).with_changes(**changes)


@simulate.command()
@_reading_options
@click.option(
    "--radius-runs",
    type=click.IntRange(min=2, max=10_000),
    default=60,
    show_default=True,
    help="Walks per fit of the sensing radius.",
)
@_size_options(
    runs=2,
    runs_help="Runs per scenario for each r_msg tried, or each search trial (--to study: "
    "give the study's 10, a unit's value is its mean over runs).",
    min_scenarios=2,
)
@click.option("--iterations", type=click.IntRange(min=2, max=20), default=4, show_default=True)
@_WORKERS
@click.option(
    "--to",
    "to",
    type=click.Choice(["published", "study", "study-teams"]),
    default="published",
    show_default=True,
    help="published: the sensing radius to g(d) and r_msg to M1's 2.46 min, one at a time; "
    "study: readings and unstated values jointly to the study's tables in full, under "
    "its unit (scenario, decision slot); study-teams: the synthetic operator population "
    "to the human-team tables (SPEC-simulation.md §11) on the default preset.",
)
@click.option(
    "--participants",
    type=click.IntRange(min=2, max=10_000),
    default=16,
    show_default=True,
    help="--to study-teams: synthetic participants per search trial (each runs M1, M2, M3).",
)
@click.option(
    "--start",
    "start",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="--to study-teams: a JSON list of persons to start the search from, after the "
    "default person and instead of the shipped fit; each names search values (traits, "
    "spread), the rest taken from the shipped fit.",
)
@click.option(
    "--budget",
    type=click.IntRange(min=1, max=100_000),
    default=120,
    show_default=True,
    help="--to study: search trials (each a reduced experiment).",
)
@click.option(
    "--finalists",
    type=click.IntRange(min=1, max=100),
    default=3,
    show_default=True,
    help="--to study: best search trials run on the full experiment.",
)
@click.option(
    "--final-runs",
    type=click.IntRange(min=1, max=10_000),
    default=10,
    show_default=True,
    help="--to study: runs per scenario and model for the finalists.",
)
@click.option(
    "--sampler-seed", type=int, default=1, show_default=True, help="--to study: the search's seed."
)
@click.option("--dask", "dask_address", default=None, help="--to study: Dask scheduler or 'local'.")
@click.option(
    "--space",
    type=click.Choice(tuple(fs.SPACES)),
    default="full",
    show_default=True,
    help="--to study: every reading and value, or M_i's readings with r_msg, d_max and "
    "F_D's wait (the rest at the default preset's values).",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/calibration"),
    show_default=True,
    help="--to study: trials (resumable), fit.json, report.md.",
)
def calibrate(
    radius_runs: int,
    scenarios: int,
    runs: int,
    iterations: int,
    workers: int,
    to: str,
    budget: int,
    finalists: int,
    final_runs: int,
    sampler_seed: int,
    dask_address: str | None,
    space: str,
    out: Path,
    participants: int,
    start: Path | None,
    **readings: Any,
) -> None:
    """Re-fit the shared calibrations from the engine and print the fit.

    --to published (the default): the sensing radius (discovery "spatial") so
    that a collective's first explorer finds a site at d after the study's
    1/g(d); then r_msg so that M1's mean decision time in the simulation-only
    experiment is 2.46 min. Copy the printed values into params.py.

    --to study: the readings and the values the paper does not state, fitted
    jointly for M1 and M2 to the study's tables in full under its unit (optuna
    over reduced experiments, then the finalists on the full one). Resumes an
    interrupted run in the same --out. Copy fit.json into presets.py.

    --to study-teams: the synthetic operators' population (median traits and
    spread) fitted to the human-team tables, all three models and both
    difficulties jointly, then judged on two held-out scenario blocks
    (hcss.experiments.operators_fit). Writes population.json (`hcss plan
    --population`) and report.md to --out (default out/operators). --start
    names the persons the search starts from (the shipped fit's search was
    started so; docs/synthetic-operators.md gives the command).
    """
    if start is not None and to != "study-teams":
        raise click.BadParameter("is for --to study-teams only", param_hint="--start")
    if to == "study-teams":
        from hcss.experiments import operators_fit as of

        try:
            starts = of.load_starts(start) if start is not None else ()
        except ValueError as error:
            raise click.BadParameter(str(error), param_hint="--start") from None
        _calibrate_to_teams(
            of.Settings(budget=budget, participants=participants, seed=sampler_seed, starts=starts),
            workers,
            dask_address,
            Path("out/operators") if out == Path("out/calibration") else out,
        )
        return
    if to == "study":
        _calibrate_to_study(
            fs.Settings(
                budget=budget,
                scenarios=scenarios,
                runs=runs,
                finalists=finalists,
                final_runs=final_runs,
                seed=sampler_seed,
                space=space,
            ),
            workers,
            dask_address,
            out,
        )
        return
    params = _params_with(**readings)
    click.echo(
        f"Calibrating with dt = {params.dt_s:g} s, discovery = {params.discovery}, "
        f"foreign_targets = {params.foreign_targets}."
    )
    if params.discovery == "spatial":
        with tqdm(total=radius_runs, unit="walk", desc="sensing radius", leave=False) as bar:
            radius = cal.fit_sensing_radius(params, runs=radius_runs, progress=bar.update)
        click.echo(
            f"\nSensing radius: {radius.radius_m:g} m "
            f"(least squares in log time over {radius.runs} walks per distance)\n"
        )
        click.echo(cal.radius_table(radius))
        params = params.with_changes(sensing_radius_m=radius.radius_m)
    else:
        click.echo("\nDiscovery per agent follows g(d) itself: no sensing radius to fit.")
    click.echo(
        f"\nMessage rate: M1, {scenarios} scenarios × {runs} runs per rate, "
        f"target {cal.STUDY_M1_DECISION_MIN} min.\n"
    )
    fit = cal.fit_message_rate(
        params,
        scenarios=scenarios,
        runs=runs,
        workers=workers,
        iterations=iterations,
        report=lambda r, m, s: click.echo(f"  r_msg {r:.3f}/s: {m:.2f} ± {s:.2f} min", err=True),
    )
    click.echo(cal.rate_table(fit))
    click.echo(
        f"\nFit: message_rate = {fit.rate:g}"
        + (
            f", sensing_radius_m = {params.sensing_radius_m:g}"
            if params.discovery == "spatial"
            else ""
        )
    )


def _calibrate_to_teams(settings: Any, workers: int, dask_address: str | None, out: Path) -> None:
    from hcss.experiments import operators_fit as of

    click.echo(
        f"Calibrating the synthetic operators to the human-team tables: {settings.budget} "
        f"search trials of {settings.participants} participants; trials kept in {out}."
    )
    try:
        study = of.open_study(out, settings)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--out") from None
    with tqdm(total=settings.budget, initial=min(of.trials_done(study), settings.budget)) as bar:

        def on_trial(e: of.Evaluation) -> None:
            bar.update(1)
            bar.set_postfix_str(f"loss {e.loss:.1f}, {e.met} met", refresh=False)

        result = of.calibrate(out, settings, workers, dask_address, on_trial=on_trial)
    click.echo(of.report(result, settings))
    click.echo(f"Written: {out / 'report.md'}, {out / 'population.json'}.")


def _calibrate_to_study(
    settings: fs.Settings, workers: int, dask_address: str | None, out: Path
) -> None:
    click.echo(
        f"Calibrating to the study's tables under its unit: {settings.budget} search trials of "
        f"{settings.scenarios} scenarios × {settings.runs} run(s), then {settings.finalists} "
        f"finalist(s) × {settings.final_runs} runs; trials kept in {out}."
    )
    try:
        study = fs.open_study(out, settings)
    except ValueError as error:
        raise click.BadParameter(str(error), param_hint="--out") from None
    done = len(fs.completed(study))
    with tqdm(
        total=settings.budget, initial=min(done, settings.budget), unit="trial", desc="search"
    ) as bar:

        def on_trial(number: int, e: fs.Evaluation) -> None:
            bar.update(1)
            bar.set_postfix_str(f"loss {e.loss:.2f}, {e.met} met", refresh=False)

        result = fs.calibrate(
            out,
            settings,
            workers,
            dask_address,
            on_trial=on_trial,
            on_finalist=lambda e: bar.write(f"finalist: loss {e.loss:.2f}, {e.met} met"),
        )
    click.echo(fs.report(result, settings))
    click.echo(f"Written: {out / 'report.md'}, {out / 'fit.json'}, {out / 'trials.csv'}.")


@simulate.command()
@_reading_options
@_size_options(runs=2, runs_help="Runs per scenario and variant.", min_scenarios=2)
@_WORKERS
@click.option(
    "--ablations/--no-ablations",
    default=True,
    show_default=True,
    help="Also run M2 without F_D, without F_R and without M_i.",
)
@click.option(
    "--seed",
    type=int,
    default=exp.DEFAULT_SCENARIO_SEED,
    show_default=True,
    help="Seed of the first scenario.",
)
def fidelity(
    scenarios: int, runs: int, workers: int, ablations: bool, seed: int, **readings: Any
) -> None:
    """The reduced experiment for M1, M2 and M2's ablations, as Markdown with standard errors.

    Also prints M1's and M2's split cells beside the study's published ones,
    and which of the study's qualitative claims (spec §10) the rows meet.
    Use --seed of a block the calibration did not search to validate a preset
    out of sample.
    """
    params = _params_with(**readings)
    click.echo(
        f"Experiment: {scenarios} scenarios × {runs} runs, scenario seeds from {seed}; "
        f"preset {params.preset}: discovery = {params.discovery}, "
        f"d_max = {params.m2_d_max_m:g} m ({params.m2_distance_bounds}), "
        f"m2_beyond_dmax = {params.m2_beyond_dmax}, foreign_targets = {params.foreign_targets}, "
        f"abandonment = {params.abandonment} (α scale {params.abandon_scale:g}), "
        f"g = {params.m2_g_reading}, r_msg = {params.message_rate:g}/s, "
        f"sensing radius = {params.sensing_radius_m:g} m, turn sd = {params.turn_sd_rad:g}.\n"
    )
    started = time.perf_counter()
    rows = fid.variant_rows(
        params,
        scenarios,
        runs,
        workers,
        ablations,
        on_variant=lambda label: click.echo(f"  running {label}", err=True),
        seed=seed,
    )
    table = fid.variant_cells(rows)
    click.echo(fid.fidelity_table(table))
    click.echo("\nPer decision, beside the study's published simulation-only results:\n")
    click.echo(fid.study_comparison(rows))
    click.echo("")
    click.echo(fid.claims_table(table))
    click.echo(f"\n{time.perf_counter() - started:.0f} s.")


@simulate.command()
@_reading_options
@click.option(
    "--runs",
    type=click.IntRange(min=2, max=1000),
    default=10,
    show_default=True,
    help="Chain and agent runs per layout and model.",
)
def meanfield(runs: int, **readings: Any) -> None:
    """The paper's equations beside the agent model on simple layouts (one collective).

    ODEs (scipy), the stochastic N-agent chain and the agent model, each on
    the easy and the difficult layout, for M1 and M2: best-site share and
    decision time. The agent model uses the current params; the mean-field
    model always discovers per agent (the paper's P_γ = v·g(d)).
    """
    from hcss.experiments import crosscheck

    params = _params_with(**readings)
    rows = [
        crosscheck.compare(layout, model, params, runs)
        for layout in crosscheck.LAYOUTS
        for model in ("M1", "M2")
    ]
    click.echo(
        f"discovery = {params.discovery}, m2_distance_bounds = {params.m2_distance_bounds}, "
        f"r_msg = {params.message_rate:g}/s\n"
    )
    click.echo(crosscheck.comparison_table(rows))


@simulate.command("sweep")
@PRESET_OPTION
@click.option(
    "--param",
    "param_specs",
    multiple=True,
    required=True,
    metavar="NAME=V1,V2,...",
    help="A parameter of Params and its values; repeat for a grid.",
)
@_size_options(runs=10, runs_help="Runs per scenario and model.")
@click.option("--models", default="M1,M2", show_default=True, help="Comma-separated models.")
@_batch_options
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/sweep"),
    show_default=True,
)
def sweep_command(
    preset: str,
    param_specs: tuple[str, ...],
    scenarios: int,
    runs: int,
    models: str,
    workers: int,
    dask_address: str | None,
    seed: int,
    out: Path,
) -> None:
    """The simulation-only experiment over every combination of the given parameter values.

    Writes OUT/cells/<cell>.csv per finished cell (an interrupted sweep resumes,
    skipping them) and OUT/decisions.csv, one row per decision with the cell's
    parameter values as columns. `hcss analyze OUT --out REPORT` draws the heat maps.
    """
    from hcss.experiments import sweep as sw

    chosen = tuple(m.strip() for m in models.split(",") if m.strip())
    if not chosen or any(m not in MODELS for m in chosen) or len(set(chosen)) != len(chosen):
        raise click.BadParameter(
            f"models must be among {', '.join(MODELS)}; got {models!r}", param_hint="--models"
        )
    try:
        axes = tuple(sw.parse_axis(spec) for spec in param_specs)
        plan = sw.Sweep(axes, scenarios, runs, chosen, seed, preset)
        n_cells = len(plan.cells)
        pending = sw.prepare(plan, out)
    except sw.SweepError as error:
        raise click.BadParameter(str(error), param_hint="--param/--out") from None
    n_jobs = len(plan.jobs())
    where = f"Dask ({dask_address})" if dask_address else f"{workers} local process(es)"
    click.echo(
        f"{n_cells} cells × {n_jobs} runs ({scenarios} scenarios × {runs} runs × "
        f"{', '.join(chosen)}) on {where}; {n_cells - len(pending)} cell(s) already written."
    )
    started = time.perf_counter()
    with tqdm(total=n_cells * n_jobs, unit="run", desc="sweep", dynamic_ncols=True) as bar:
        ran = sw.run_sweep(plan, out, workers, dask_address, on_done=bar.update)
    elapsed = time.perf_counter() - started
    click.echo(f"{ran} cell(s) run in {elapsed:.0f} s; all decisions in {out / 'decisions.csv'}.")


def _structure_axes() -> tuple[
    tuple[str, ...], tuple[float, ...], tuple[float, ...], tuple[str, ...]
]:
    """The structure map's default grid, as structure.py defines it."""
    from hcss.experiments import structure as st

    return st.DISCOVERY, st.D_MAX_M, st.WAIT_SCALES, tuple(st.MECHANISMS)


@simulate.command()
@click.option(
    "--preset",
    type=click.Choice(tuple(PRESETS)),
    default="study-units",
    show_default=True,
    help="Every value the grid does not set (the preset fitted under the study's unit).",
)
@click.option(
    "--runs",
    type=click.IntRange(min=1, max=1000),
    default=8,
    show_default=True,
    help="Agent-model runs per layout and cell.",
)
@click.option(
    "--discovery",
    default=",".join(_structure_axes()[0]),
    show_default=True,
    help="Comma-separated discovery readings of the grid.",
)
@click.option(
    "--d-max",
    default=",".join(f"{d:g}" for d in _structure_axes()[1]),
    show_default=True,
    help="Comma-separated d_max values (m).",
)
@click.option(
    "--wait-scale",
    default=",".join(f"{w:g}" for w in _structure_axes()[2]),
    show_default=True,
    help="Comma-separated F_D wait scales.",
)
@click.option(
    "--mechanisms",
    default=",".join(_structure_axes()[3]),
    show_default=True,
    help="Comma-separated sets of M2's mechanisms.",
)
@click.option(
    "--uses",
    default="queue+recruitment+inhibition",
    show_default=True,
    help="Comma-separated sets (each '+'-joined) of the uses carrying M2's M_i.",
)
@click.option(
    "--m1-queue",
    default="unmodulated",
    show_default=True,
    help="Comma-separated: M1's queue messages unmodulated or modulated by M_i.",
)
@click.option(
    "--d-min",
    default="search_space",
    show_default=True,
    help="Comma-separated d_min readings of M_i: search_space, nearest_site.",
)
@click.option(
    "--out",
    type=click.Path(file_okay=False, path_type=Path),
    default=Path("out/structure"),
    show_default=True,
)
def structure(
    preset: str,
    runs: int,
    discovery: str,
    d_max: str,
    wait_scale: str,
    mechanisms: str,
    uses: str,
    m1_queue: str,
    d_min: str,
    out: Path,
) -> None:
    """Issue 28's structural question as a map: M1's and M2's P(best) and decision time on
    three one-collective layouts, mean-field and agent model, over the discovery reading
    (per agent, per collective, per returning discoverer), d_max, F_D's wait scale and M2's
    mechanisms. Writes OUT/structure.csv and OUT/structure.md and prints the table."""
    from hcss.experiments import structure as st

    def axis(text: str, name: str, allowed: tuple[str, ...] | None = None) -> list[str]:
        values = [v.strip() for v in text.split(",") if v.strip()]
        if not values or (allowed and any(v not in allowed for v in values)):
            raise click.BadParameter(
                f"comma-separated values among {', '.join(allowed or ('numbers',))}; got {text!r}",
                param_hint=name,
            )
        return values

    try:
        cells = list(
            st.grid(
                axis(discovery, "--discovery", st.DISCOVERY),
                [float(v) for v in axis(d_max, "--d-max")],
                [float(v) for v in axis(wait_scale, "--wait-scale")],
                axis(mechanisms, "--mechanisms", tuple(st.MECHANISMS)),
                axis(uses, "--uses"),
                axis(m1_queue, "--m1-queue"),
                axis(d_min, "--d-min"),
            )
        )
        for cell in cells:  # a value the params refuse, before any run
            cell.params(preset_params(preset))
    except ValueError as error:  # a number that is not one, or one the params refuse
        raise click.BadParameter(
            str(error), param_hint="--d-max/--wait-scale/--uses/--m1-queue/--d-min"
        ) from None
    click.echo(
        f"{len(cells)} cells × {len(st.LAYOUTS)} layouts × {runs} agent runs, preset {preset}."
    )
    started = time.perf_counter()
    with tqdm(total=len(cells), unit="cell", desc="structure", dynamic_ncols=True) as bar:
        rows = st.run_map(preset_params(preset), runs, cells, on_cell=bar.update)
    st.write_map(rows, out / "structure.csv")
    table = st.summary_markdown(rows)
    (out / "structure.md").write_text(
        f"# The structural question (issue 28), preset {preset}, {runs} agent runs per cell\n\n"
        f"{table}\n",
        encoding="utf-8",
    )
    click.echo(table)
    click.echo(
        f"{len(rows)} rows in {out / 'structure.csv'} ({time.perf_counter() - started:.0f} s)."
    )
