"""Snapshots stay readable across adjacent versions (docs/operations.md, "Rolling upgrade").

Each release commits its fixtures under snapshot_fixtures/v<version>/ (written
by write_fixture.py there): a live trial's snapshot, its command log and the
state digests its own code reached. Today's code must rebuild every stored
version's trial bit for bit, from the snapshot and from the trial's start
(the rebuild's fallback for a snapshot of a newer format), so the previous
release's fixture passing here is what lets the two run side by side.
"""

from __future__ import annotations

import gzip
import io
import json
import pickle
from importlib.metadata import version
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hcss.simulation import (
    NewerSnapshotFormat,
    OperatorCommand,
    Params,
    Scenario,
    Simulation,
    SimulationError,
)
from hcss.simulation import snapshots as snapshot_format_module
from hcss.simulation.operators import InvestigateThenDecide, OperatedRun
from hcss.simulation.replay import TimedCommand, replay
from hcss.simulation.snapshots import SNAPSHOT_FORMAT, snapshot_format
from tests.support.snapshot_formats import newer, restamped

FIXTURES = Path(__file__).resolve().parent / "snapshot_fixtures"
STORED = sorted(FIXTURES.glob("v*/*.json"))


def _fixture(path: Path) -> tuple[dict[str, Any], bytes, list[TimedCommand]]:
    fixture = json.loads(path.read_text())
    blob = gzip.decompress(path.with_name(f"{fixture['model']}.snapshot.gz").read_bytes())
    commands = [
        (step, OperatorCommand(kind, collective, target, request_id))
        for step, kind, collective, target, request_id in fixture["commands"]
    ]
    return fixture, blob, commands


def _from_the_start(fixture: dict[str, Any]) -> Simulation:
    return Simulation(
        Scenario.from_dict(fixture["scenario"]),
        fixture["model"],
        Params.from_dict(fixture["params"]),
        run=fixture["run"],
    )


def _name(path: Path) -> str:
    return f"{path.parent.name}-{path.stem}"


def test_this_version_has_its_fixtures() -> None:
    """A release writes its own (write_fixture.py), so that the next one is tested against it."""
    assert (FIXTURES / f"v{version('hcss')}").is_dir()
    assert len(STORED) >= 3


@pytest.mark.parametrize("path", STORED, ids=_name)
def test_a_stored_snapshot_continues_bit_for_bit(path: Path) -> None:
    """The rebuild's path: restore the snapshot, replay the commands it does not hold."""
    fixture, blob, commands = _fixture(path)
    sim = Simulation.restore(blob)
    assert sim.step_count == fixture["snapshot"]["step"]
    assert sim.state_digest() == fixture["snapshot"]["digest"]
    held = fixture["snapshot"]["commands_held"]
    assert 0 < held < len(commands)
    assert any(step == sim.step_count for step, _ in commands[held:])  # logged at its very step
    sim = replay(sim.scenario, sim.model, commands, fixture["until_step"], start=sim, held=held)
    assert sim.step_count == fixture["until_step"]
    assert sim.state_digest() == fixture["digest"]
    assert len(sim.decisions) == fixture["decisions"]


@pytest.mark.parametrize("path", STORED, ids=_name)
def test_a_stored_trial_replays_from_its_start_bit_for_bit(path: Path) -> None:
    """The fallback for a snapshot of a format this version does not read: the same steps
    from the trial's start with the whole log reach the same state."""
    fixture, _, commands = _fixture(path)
    sim = replay(
        Scenario.from_dict(fixture["scenario"]),
        fixture["model"],
        commands,
        fixture["until_step"],
        start=_from_the_start(fixture),
    )
    assert sim.state_digest() == fixture["digest"]


@pytest.mark.parametrize(
    "path",
    [p for p in STORED if json.loads(p.read_text())["snapshot_format"] == SNAPSHOT_FORMAT],
    ids=_name,
)
def test_the_format_number_changes_when_the_layout_does(path: Path) -> None:
    """Today's code writes a stored snapshot of its own format with the same layout.

    If not, the bytes changed (a field, a class or its module, numpy's pickled
    form, an array's dtype or rank) under the same number, and the previous
    version would misread them instead of falling back: raise SNAPSHOT_FORMAT
    (hcss/simulation/snapshots.py). Values are not compared here (the digests
    are, above), nor bytes: equal values pickle differently when shared.
    """
    fixture, blob, commands = _fixture(path)
    held = fixture["snapshot"]["commands_held"]
    sim = replay(
        Scenario.from_dict(fixture["scenario"]),
        fixture["model"],
        commands[:held],
        fixture["snapshot"]["step"],
        start=_from_the_start(fixture),
    )
    assert _layout(sim.snapshot()) == _layout(blob)


def _layout(blob: bytes) -> tuple[set[tuple[str, str]], str]:
    """The classes a snapshot names and the shape of its state: keys, attributes, types,
    arrays' dtypes and ranks."""
    named: set[tuple[str, str]] = set()

    class Recording(pickle.Unpickler):
        def find_class(self, module: str, name: str) -> Any:
            named.add((module, name))
            return super().find_class(module, name)

    return named, repr(_shape(Recording(io.BytesIO(blob)).load()))


def _shape(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return ("array", value.dtype.str, value.ndim)
    if isinstance(value, dict):
        return {key: _shape(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return (type(value).__name__, sorted({repr(_shape(item)) for item in value}))
    if hasattr(value, "__dict__"):
        return (type(value).__qualname__, _shape(vars(value)))
    return type(value).__name__


@pytest.fixture(scope="module")
def operated() -> Simulation:
    run = OperatedRun(Simulation(Scenario.generate(8), "M1"), InvestigateThenDecide())
    run.run(until_s=120)
    assert run.sim.requests and run.sim.decisions
    return run.sim


def test_the_format_is_read_without_unpickling(operated: Simulation) -> None:
    assert snapshot_format(operated.snapshot()) == SNAPSHOT_FORMAT
    assert snapshot_format(newer(operated.snapshot())) == SNAPSHOT_FORMAT + 1
    assert snapshot_format(b"not a pickle") is None
    assert snapshot_format(pickle.dumps([1, 2])) is None


def test_a_newer_format_is_refused_as_newer_even_when_it_cannot_be_unpickled(
    operated: Simulation,
) -> None:
    blob = newer(operated.snapshot())
    with pytest.raises(ModuleNotFoundError):
        pickle.loads(blob)  # names a module only the newer version has
    with pytest.raises(NewerSnapshotFormat) as refused:
        Simulation.restore(blob)
    assert refused.value.found == SNAPSHOT_FORMAT + 1
    assert f"format {SNAPSHOT_FORMAT + 1} is newer" in str(refused.value)
    # Found in the unpickled state too, when the stamp is not first.
    state = pickle.loads(operated.snapshot())
    state["version"] = SNAPSHOT_FORMAT + 1
    with pytest.raises(NewerSnapshotFormat):
        Simulation.restore(pickle.dumps(state, protocol=5))


def test_a_retired_format_is_refused_saying_so(operated: Simulation) -> None:
    with pytest.raises(SimulationError, match="format 2 is older than this version reads"):
        Simulation.restore(restamped(operated.snapshot(), 2))


def test_a_snapshot_stamped_last_restores(operated: Simulation) -> None:
    """Snapshots written before the stamp came first (format 3, `version` the last key)."""
    state = pickle.loads(operated.snapshot())
    state["version"] = state.pop("version")
    blob = pickle.dumps(state, protocol=5)
    assert snapshot_format(blob) is None
    restored = Simulation.restore(blob)
    assert restored.state_digest() == operated.state_digest()


def test_an_older_format_is_converted_before_it_is_restored(
    operated: Simulation, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As a release that renames a field reads its predecessor's snapshots: through a converter.

    Planted: this version's state as "format N" with `commands_applied` named
    `applied`, read by a "format N + 1" whose converter renames it back.
    """
    state = pickle.loads(operated.snapshot())
    state["applied"] = state.pop("commands_applied")
    old = pickle.dumps(state, protocol=5)
    monkeypatch.setattr(snapshot_format_module, "SNAPSHOT_FORMAT", SNAPSHOT_FORMAT + 1)

    def renamed(before: dict[str, Any]) -> dict[str, Any]:
        after = dict(before)
        after["commands_applied"] = after.pop("applied")
        return after

    monkeypatch.setattr(snapshot_format_module, "CONVERTERS", {SNAPSHOT_FORMAT: renamed})
    restored = Simulation.restore(old)
    assert restored.commands_applied == operated.commands_applied > 0
    assert not hasattr(restored, "applied")
    restored.step(30)
    operated_copy = Simulation.restore(operated.snapshot())
    operated_copy.step(30)
    assert restored.state_digest() == operated_copy.state_digest()
