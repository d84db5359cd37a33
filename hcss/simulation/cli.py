"""`hcss simulate demo`: the model's own command, for whoever wants to watch a trial run.

The experiment commands (`experiment`, `sweep`, `calibrate`, `fidelity`,
`meanfield`) live with the experiments (hcss.experiments.cli); hcss/cli.py
lists both groups under the one `hcss simulate`.
"""

from __future__ import annotations

import time

import click
from tqdm import tqdm

from hcss.simulation.engine import Simulation
from hcss.simulation.messages import collective_name, event_text
from hcss.simulation.params import MODELS
from hcss.simulation.presets import DEFAULT_PRESET, PRESETS, preset_params
from hcss.simulation.scenario import Scenario
from hcss.simulation.view import Display


@click.group()
def simulate() -> None:
    """Model commands: run one trial of the model."""


PRESET_OPTION = click.option(
    "--preset",
    type=click.Choice(tuple(PRESETS)),
    default=DEFAULT_PRESET,
    show_default=True,
    help="Named parameter set (docs/simulation-notes.md); readings given below override it.",
)


@simulate.command()
@click.option("--model", type=click.Choice(MODELS), default="M1", show_default=True)
@PRESET_OPTION
@click.option("--seed", type=int, default=1, show_default=True, help="Scenario seed.")
@click.option(
    "--first-section", type=click.Choice(["easy", "difficult"]), default="easy", show_default=True
)
@click.option(
    "--speed",
    type=click.FloatRange(min=0.1),
    default=30.0,
    show_default=True,
    help="Simulated seconds per wall-clock second (1 = live pace).",
)
@click.option(
    "--minutes",
    type=click.FloatRange(min=0.1),
    default=20.0,
    show_default=True,
    help="Trial length.",
)
def demo(
    model: str, preset: str, seed: int, first_section: str, speed: float, minutes: float
) -> None:
    """A four-collective trial, paced against the wall clock, with a live text summary."""
    params = preset_params(preset)
    scenario = Scenario.generate(seed, first_section=first_section, params=params)
    sim = Simulation(scenario, model, params)
    limit = minutes * 60.0
    click.echo(
        f"{model} trial ({preset}), seed {seed}, {first_section} section first, "
        f"{speed:g}x real time. Ctrl-C stops."
    )
    started = time.monotonic()
    bar = tqdm(total=int(limit), unit="sim s", desc="trial", dynamic_ncols=True)
    try:
        while not sim.finished and sim.time < limit:
            due = (time.monotonic() - started) * speed
            while sim.time < min(due, limit) and not sim.finished:
                sim.step()
            for event in sim.drain_events():
                bar.write(f"[{_clock(event['time'])}] {event_text(event)}")
            bar.set_postfix_str(_status(sim.display()), refresh=False)
            bar.update(int(sim.time) - bar.n)
            time.sleep(0.05)
    except KeyboardInterrupt:
        bar.write("stopped")
    bar.close()
    correct = sum(d.correct for d in sim.decisions)
    click.echo(
        f"{len(sim.decisions)} decisions, {correct} correct, in {_clock(sim.time)} of simulated time."
    )


def _clock(seconds: float) -> str:
    return f"{int(seconds) // 60:02d}:{int(seconds) % 60:02d}"


def _status(display: Display) -> str:
    parts = []
    for c in range(display.n_collectives):
        u, f, com, x = display.state_counts[c] / display.n_agents  # states.QUADRANTS
        move = f"→{display.move_target[c]}" if display.move_target[c] else ""
        parts.append(f"{collective_name(c)} U{u:.0%} F{f:.0%} C{com:.0%} X{x:.0%}{move}")
    return f"section {display.section} | " + " | ".join(parts)
