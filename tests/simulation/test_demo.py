"""`hcss simulate demo`: a paced trial with a text summary of what the display shows."""

from __future__ import annotations

from click.testing import CliRunner

from hcss.simulation import Scenario, Simulation
from hcss.simulation.cli import _status, simulate


def test_the_demo_runs_to_its_summary() -> None:
    result = CliRunner().invoke(simulate, ["demo", "--minutes", "0.5", "--speed", "600"])
    assert result.exit_code == 0, result.output
    assert "decisions" in result.output


def test_the_status_line_shows_each_collectives_hub_estimates() -> None:
    sim = Simulation(Scenario.generate(2, first_section="easy"), "M1")
    line = _status(sim.display())
    assert line == "section 1 | " + " | ".join(
        f"{c} U100% F0% C0% X0%" for c in ["I", "II", "III", "IV"]
    )
