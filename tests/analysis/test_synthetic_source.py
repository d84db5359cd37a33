"""Synthetic participants (`hcss plan`) are analysed as a study's teams, never beside real ones
unless asked."""

from __future__ import annotations

from pathlib import Path

import pytest

from hcss.analysis.load import AnalysisInputError, load_inputs
from hcss.experiments.synthetic_trials import run_trial
from hcss.simulation import Scenario
from hcss.simulation.presets import preset_params
from hcss.simulation.synthetic import Population, SyntheticOperator
from hcss.tablespec import DECISIONS
from hcss.tidy_csv import write_rows


@pytest.fixture(scope="module")
def synthetic_rows() -> list[dict[str, object]]:
    params = preset_params()
    scenario = Scenario.generate(3, first_section="easy", params=params)
    operator = SyntheticOperator(Population().participant(3), 3)
    _, rows = run_trial(scenario, "M1", params, operator, "syn-3", "syn-3-M1", 600.0)
    assert rows.decisions and {d["source"] for d in rows.decisions} == {"synthetic"}
    return rows.decisions


def test_synthetic_decisions_are_read_as_teams_with_a_warning(
    tmp_path: Path, synthetic_rows: list[dict[str, object]]
) -> None:
    write_rows(tmp_path / "decisions.csv", DECISIONS.names, synthetic_rows)
    tables = load_inputs([tmp_path], include_pilot=True)
    assert tables.groups == ["M1"]
    assert any("synthetic participant" in w for w in tables.warnings)


def test_synthetic_beside_real_participants_is_refused_unless_pooled(
    tmp_path: Path, synthetic_rows: list[dict[str, object]]
) -> None:
    real = [row | {"source": "study", "participant": "P001"} for row in synthetic_rows]
    write_rows(tmp_path / "decisions.csv", DECISIONS.names, [*synthetic_rows, *real])
    with pytest.raises(AnalysisInputError, match="pool-synthetic"):
        load_inputs([tmp_path], include_pilot=True)
    pooled = load_inputs([tmp_path], include_pilot=True, pool_synthetic=True)
    assert set(pooled.decisions["participant"]) == {"syn-3", "P001"}
