"""`hcss simulate fidelity`: cells with standard errors, the ablations and the claims."""

from __future__ import annotations

import math

import pytest
from click.testing import CliRunner

from hcss.cli import main
from hcss.experiments import experiment as exp
from hcss.experiments import fidelity as fid
from hcss.simulation import Params


def _row(
    trial: str, difficulty: str, correct: bool, seconds: float, timed_out: bool = False
) -> dict:
    return {
        "trial_id": trial,
        "difficulty": difficulty,
        "correct": correct,
        "decision_time_s": seconds,
        "timed_out": timed_out,
    }


def test_cells_give_trial_success_and_decision_time_with_standard_errors() -> None:
    rows = [
        _row("a", "easy", True, 60),
        _row("a", "easy", False, 120),
        _row("a", "difficult", False, 180),
        _row("b", "easy", True, 240),
        _row("b", "difficult", True, 300, timed_out=True),
    ]
    easy = {c.split: c for c in fid.cells("M1", rows)}["easy"]
    # Trial success: a 1/2, b 1/1 → mean 0.75, SD √((0.25² · 2)/1) = 0.3536, SE 0.3536/√2 = 0.25.
    assert easy.success == pytest.approx(0.75)
    assert easy.success_se == pytest.approx(0.25)
    # Times 1, 2, 4 min: mean 7/3, SD √(((−4/3)² + (−1/3)² + (5/3)²)/2) = 1.5275, SE /√3 = 0.8819.
    assert easy.time_min == pytest.approx(7 / 3)
    assert easy.time_se == pytest.approx(1.5275 / math.sqrt(3), rel=1e-4)
    overall = {c.split: c for c in fid.cells("M1", rows)}["overall"]
    assert overall.timed_out == pytest.approx(0.2)


def test_each_ablation_removes_exactly_one_mechanism_of_m2() -> None:
    runs = fid.variants(Params())
    assert [label for label, _, _ in runs] == [
        "M1",
        "M2",
        "M2 without F_D",
        "M2 without F_R",
        "M2 without M_i",
    ]
    for label, model, params in runs[2:]:
        assert model == "M2"
        assert len(params.m2_mechanisms) == 2
        removed = set(Params().m2_mechanisms) - set(params.m2_mechanisms)
        assert fid.ABLATIONS[removed.pop()] == label
        # Nothing else differs: an ablation is not a parameter change.
        assert params.with_changes(m2_mechanisms=Params().m2_mechanisms) == Params()


def test_claims_are_judged_on_the_rows(monkeypatch: pytest.MonkeyPatch) -> None:
    def fake_run_jobs(
        jobs: list[exp.Job], workers: int, params: Params | None = None
    ) -> list[dict]:
        model = jobs[0].model
        good = model == "M2"
        return [
            _row(f"t{i}", kind, good or kind == "easy", 150 if model == "M1" else 270)
            for i in range(3)
            for kind in ("easy", "difficult")
        ]

    monkeypatch.setattr(fid.exp, "run_jobs", fake_run_jobs)
    rows = fid.variant_rows(Params(), scenarios=2, runs=1, workers=1, ablations=False)
    table = fid.variant_cells(rows)
    verdict = {claim: met for claim, met, _ in fid.claims(table)}
    assert all(verdict.values())
    assert "| M2 | difficult | 3 | 1.000 ± 0.000 |" in fid.fidelity_table(table)


@pytest.mark.parametrize("args", [["--runs", "0"], ["--scenarios", "1"], ["--m2-beyond-dmax", "x"]])
def test_fidelity_refuses_bad_options(args: list[str]) -> None:
    result = CliRunner().invoke(main, ["simulate", "fidelity", *args])
    assert result.exit_code == 2
    assert "Traceback" not in result.output
