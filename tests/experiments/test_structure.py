"""The structural map of issue 28: its readings, its verdict and its table."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import structure as st
from hcss.simulation import Params
from hcss.simulation.presets import preset_params


def test_the_returning_discoverer_reading_is_g_less_the_flight_home() -> None:
    """If the fitted data were times until a discoverer is back, an explorer finds a site at
    γ(d) = 1/(1/g(d) − d/speed): faster than g, and fitted by the same curve within 3%."""
    base = Params()
    params, scale = st.reading_params(base, "returning_discoverer")
    assert scale == 1.0 and params.discovery == "per_agent"
    d = np.array([150.0, 250.0, 350.0, 500.0])
    wanted = 1.0 / (1.0 / np.asarray(base.discovery_rate(d)) - d / base.speed_mps)
    fitted = np.asarray(params.discovery_rate(d))
    assert fitted == pytest.approx(wanted, rel=0.03)
    assert np.all(fitted > np.asarray(base.discovery_rate(d)))


def test_per_collective_discovery_is_spatial_and_g_shared_by_the_expected_explorers() -> None:
    params, scale = st.reading_params(Params(), "per_collective")
    assert params.discovery == "spatial"
    assert scale == pytest.approx(1 / 180)  # P_L/(P_L + P_U^I) = 0.9 of 200 agents
    with pytest.raises(ValueError, match="per_agent, per_collective, returning_discoverer"):
        st.reading_params(Params(), "per_site")


def test_an_m2_cell_sets_only_m2s_delays_and_mechanisms_beside_its_discovery_reading() -> None:
    base = preset_params("study-units")
    m1, _ = st.Cell("per_agent", "M1").params(base)
    m2, _ = st.Cell("per_agent", "M2", 352.0, 0.05, "no_F_R").params(base)
    assert m2 == m1.with_changes(
        fitted_d_max_m=352.0,
        m2_discovery_wait_scale=0.05,
        m2_mechanisms=("discovery_delay", "modulation"),
    )
    cells = list(st.grid())
    assert len(cells) == 3 * (1 + 3 * 3 * 3)
    assert sum(c.model == "M1" for c in cells) == 3


def _row(
    model: str, layout: str, method: str, p: float, minutes: float, d_max_m: float
) -> dict[str, object]:
    return {
        "discovery": "per_agent",
        "model": model,
        "d_max_m": d_max_m,
        "wait_scale": 1.0,
        "mechanisms": "all",
        "layout": layout,
        "method": method,
        "p_best": p,
        "time_min": minutes,
    }


def test_the_summary_says_which_m2_cells_reach_the_studys_easy_cell_at_its_time() -> None:
    rows = []
    # (best nearest, best furthest) per cell: in band; too slow on easy; too weak on difficult.
    for d_max, near, far in (
        (430.0, (0.8, 4.5), (0.6, 5.0)),
        (500.0, (0.9, 6.0), (0.9, 4.0)),
        (352.0, (0.9, 3.5), (0.3, 2.0)),
    ):
        for method in ("mean-field", "agent"):
            rows.append(_row("M2", "best_nearest", method, *near, d_max))
            rows.append(_row("M2", "best_middle", method, 0.5, 4.0, d_max))
            rows.append(_row("M2", "best_furthest", method, *far, d_max))
    table = st.summary_markdown(rows)
    verdicts = [line.rsplit("|", 2)[1].strip() for line in table.splitlines() if "| M2 |" in line]
    assert verdicts == ["yes / yes", "no / no", "no / no"]
    assert "1 of 3 (mean-field), 1 of 3 (agent model)" in table


def test_the_map_measures_both_models_on_every_layout_and_writes_a_tidy_csv(tmp_path: Path) -> None:
    rows = st.run_map(Params(), runs=2, cells=[st.Cell("per_agent", "M1")])
    assert {(r["layout"], r["method"]) for r in rows} == {
        (layout, method) for layout in st.LAYOUTS for method in ("mean-field", "agent")
    }
    mean_field = {r["layout"]: r for r in rows if r["method"] == "mean-field"}
    # The paper's M1 is a nearest-site picker in its own equations.
    assert mean_field["best_nearest"]["p_best"] > 0.9
    assert mean_field["best_middle"]["p_best"] < 0.1
    assert mean_field["best_furthest"]["p_best"] < 0.1
    st.write_map(rows, tmp_path / "structure.csv")
    with (tmp_path / "structure.csv").open(newline="", encoding="utf-8") as handle:
        read = list(csv.DictReader(handle))
    assert tuple(read[0]) == st.COLUMNS and len(read) == 6
    assert {r["d_max_m"] for r in read} == {""}  # M1 has no delays: empty, not "None"


def test_the_structure_command_maps_the_grid_it_is_given(tmp_path: Path) -> None:
    args = ["simulate", "structure", "--runs", "1", "--out", str(tmp_path)]
    one_cell = ["--discovery", "per_agent", "--d-max", "352", "--wait-scale", "1"]
    result = CliRunner().invoke(main, [*args, *one_cell, "--mechanisms", "no_M_i"])
    assert result.exit_code == 0, result.output
    with (tmp_path / "structure.csv").open(newline="", encoding="utf-8") as handle:
        read = list(csv.DictReader(handle))
    assert len(read) == 2 * 3 * 2  # M1 and one M2 cell, three layouts, two methods
    assert {r["mechanisms"] for r in read if r["model"] == "M2"} == {"no_M_i"}
    assert (
        "| per_agent | unmodulated | search_space | M2 | 352 m | 1 | no_M_i | "
        "queue+recruitment+inhibition |" in (tmp_path / "structure.md").read_text()
    )
    bad_grids = (
        ["--mechanisms", "no_F_X"],
        ["--d-max", "far"],
        ["--d-max", "100"],  # not above d_min (150 m)
        ["--wait-scale", "0"],
        ["--discovery", ""],
        ["--uses", "queue+bogus"],
        ["--m1-queue", "sometimes"],
        ["--d-min", "hub"],
    )
    for bad in bad_grids:
        result = CliRunner().invoke(main, [*args, *bad])
        assert result.exit_code == 2 and "Traceback" not in result.output, bad


def test_the_map_carries_m_i_s_uses_m1_s_queue_and_d_min_to_both_methods(tmp_path: Path) -> None:
    """Issue 39's readings are axes of the map: each cell's params carry them, and the
    command writes them beside the cell's measurements."""
    cells = list(
        st.grid(
            ["per_agent"],
            [352.0],
            [0.15],
            ["all"],
            ["recruitment", "queue+recruitment+inhibition"],
            ["unmodulated", "modulated"],
            ["nearest_site"],
        )
    )
    assert [c.model for c in cells] == ["M1", "M2", "M2", "M1", "M2", "M2"]
    m2, _ = cells[4].params(preset_params("study-units"))
    assert m2.m2_modulation_uses == ("recruitment",)
    assert (m2.m1_queue_modulation, m2.m2_d_min) == ("modulated", "nearest_site")
    m1, _ = cells[3].params(preset_params("study-units"))
    assert m1.m1_queue_modulation == "modulated" and m1.m2_d_min == "nearest_site"
    args = ["simulate", "structure", "--runs", "1", "--out", str(tmp_path)]
    one_cell = ["--discovery", "per_agent", "--d-max", "352", "--wait-scale", "0.15"]
    result = CliRunner().invoke(
        main,
        [
            *args,
            *one_cell,
            "--mechanisms",
            "all",
            "--uses",
            "recruitment",
            "--m1-queue",
            "modulated",
        ],
    )
    assert result.exit_code == 0, result.output
    with (tmp_path / "structure.csv").open(newline="", encoding="utf-8") as handle:
        read = list(csv.DictReader(handle))
    assert {r["uses"] for r in read if r["model"] == "M2"} == {"recruitment"}
    assert {r["m1_queue"] for r in read} == {"modulated"}
    # M1's queue messages at r·M_i make its far sites' quorums likelier: the equations say so.
    plain = st.measure(st.Cell("per_agent", "M1"), preset_params("study-units"), runs=1)
    queued = [r for r in read if r["model"] == "M1" and r["method"] == "mean-field"]
    far = {r["layout"]: float(r["p_best"]) for r in queued}
    before = {r["layout"]: r["p_best"] for r in plain if r["method"] == "mean-field"}
    assert far["best_furthest"] > before["best_furthest"]
