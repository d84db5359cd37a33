"""Write this version's snapshot fixtures: `python tests/simulation/snapshot_fixtures/write_fixture.py`.

Run at each release, after raising the version in pyproject.toml and
reinstalling (docs/operations.md, "Rolling upgrade"). It writes
``v<version>/`` beside this file: for each model, a live trial's snapshot
(``<model>.snapshot.gz``, the `Simulation.snapshot()` bytes, gzipped) and
``<model>.json``: the trial's scenario, parameters and whole command log, the
step the snapshot was taken at with how many of the commands it holds, and
the state digests at that step and at a later one. The directories of
earlier versions stay: tests/simulation/test_snapshot_compat.py rebuilds
every one of them with today's code, bit for bit, so a release that cannot
continue its predecessor's trials fails its own tests.

The trial is a live trial's (the bundled study's preset, no decision time
limit, run 0), driven by a scripted operator that also sends commands the
simulation refuses and cancels abandon orders, so the log holds every kind.
"""

from __future__ import annotations

import argparse
import gzip
import json
import platform
import sys
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np

from hcss.simulation import MODELS, OperatorCommand, Scenario, Simulation
from hcss.simulation.operators import InvestigateThenDecide
from hcss.simulation.presets import STUDY_CALIBRATED, preset_params
from hcss.simulation.snapshots import SNAPSHOT_FORMAT

HERE = Path(__file__).resolve().parent
SEED = 2
SNAPSHOT_STEP = 160  # mid-trial, decisions made, requests under way; commands follow at once
UNTIL_STEP = 300  # the digest the rebuild must reach
LOOK_EVERY = 4  # steps between the operator's looks


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--replace", action="store_true", help="overwrite this version's fixtures (unreleased only)"
    )
    args = parser.parse_args(argv)
    folder = HERE / f"v{version('hcss')}"
    if folder.exists() and not args.replace:
        print(
            f"{folder} exists: a released version's fixtures are never rewritten", file=sys.stderr
        )
        return 1
    folder.mkdir(exist_ok=True)
    for model in MODELS:
        blob, fixture = operated_trial(model)
        (folder / f"{model}.snapshot.gz").write_bytes(gzip.compress(blob, mtime=0))
        (folder / f"{model}.json").write_text(json.dumps(fixture, separators=(",", ":")) + "\n")
    print(f"wrote {folder}")
    return 0


def operated_trial(model: str) -> tuple[bytes, dict[str, Any]]:
    """The snapshot at SNAPSHOT_STEP and the fixture that says how to continue it."""
    params = preset_params(STUDY_CALIBRATED).with_changes(decision_timeout_s=None)
    scenario = Scenario.generate(SEED, first_section="easy", params=params)
    sim = Simulation(scenario, model, params)
    policy = InvestigateThenDecide(abandon_below=0.15)
    log: list[tuple[int, OperatorCommand]] = []
    blob, held, digest_then = b"", 0, ""
    while sim.step_count < UNTIL_STEP and not sim.finished:
        if sim.step_count == SNAPSHOT_STEP:
            blob, held, digest_then = sim.snapshot(), len(log), sim.state_digest()
        if sim.step_count % LOOK_EVERY == 0:
            for command in _looked(sim, policy):
                sim.apply(command)
                log.append((sim.step_count, command))
        sim.step()
    if not blob or sim.step_count != UNTIL_STEP:
        raise SystemExit(f"{model}: the trial ended before step {UNTIL_STEP}; pick another")
    fixture = {
        "hcss": version("hcss"),
        "snapshot_format": SNAPSHOT_FORMAT,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "model": model,
        "run": sim.run,
        "scenario": scenario.to_dict(),
        "params": params.to_dict(),
        "commands": [_command(step, command) for step, command in log],
        "snapshot": {"step": SNAPSHOT_STEP, "commands_held": held, "digest": digest_then},
        "until_step": UNTIL_STEP,
        "digest": sim.state_digest(),
        "decisions": len(sim.decisions),
    }
    return blob, fixture


def _looked(sim: Simulation, policy: InvestigateThenDecide) -> list[OperatorCommand]:
    """The policy's requests, a decide the map does not show (refused) every 20 steps,
    and a cancel of the oldest abandon order every 40."""
    commands = policy.commands(sim.display())
    if sim.step_count % 20 == 0:
        commands.append(OperatorCommand("decide", 1, 999))
    abandons = [r.id for r in sim.requests if r.kind == "abandon" and r.active]
    if sim.step_count % 40 == 0 and abandons:
        commands.append(OperatorCommand.cancel(abandons[0]))
    return commands


def _command(step: int, command: OperatorCommand) -> list[Any]:
    return [step, command.kind, command.collective, command.target, command.request_id]


if __name__ == "__main__":
    sys.exit(main())
