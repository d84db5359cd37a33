"""The study's words about its operators, read on teams' means, and how often a study of N
participants bears each out."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import norm

from hcss.experiments import study_claims
from hcss.experiments import study_teams as teams
from hcss.experiments.synthetic_trials import TrialRows


def _study_means(**changes: float) -> dict:
    """§11's means as measured cells, some changed ("measure|model|column" keys)."""
    means = {cell.key: cell.mean for cell in teams.STUDY_TEAMS}
    for name, value in changes.items():
        means[tuple(name.split("|"))] = value
    return {key: teams.Measured(mean, 0.0, 1) for key, mean in means.items()}


def test_the_studys_own_tables_bear_out_its_words_about_its_operators() -> None:
    """Each sentence is coded so that §11's means (and §10's collectives alone) meet it: the
    check on the coding is the study's own numbers, read by hand in the docstring."""
    made = study_claims.claims(_study_means(), study_claims.STUDY_ALONE)
    assert [c.met for c in made] == [True] * 6
    assert "M2 - M1 easy +1.27 min" in made[1].measured  # 3.37 - 2.1
    assert "+27 s" in made[2].measured  # 4.67 - 4.22 = 0.45 min
    assert "M1 4%, M2 3%, M3 2%" in made[5].measured  # 0.02/0.57, 0.02/0.66, 0.03/1.33
    assert study_claims.claims(_study_means())[0].met is None  # no collectives alone: not measured
    # the plan's table of chances names the sentences in the order claims reads them
    assert [c.words for c in made] == list(study_claims.SENTENCES)


@pytest.mark.parametrize(
    ("changes", "alone", "broken"),
    [
        ({}, {("M2", "difficult"): 85.0}, 0),  # alone better than the teams' 81.41
        ({"time_min|M2|easy": 3.0}, {}, 1),  # only 0.9 min longer than M1's 2.1
        ({"time_min|M2|difficult": 4.8}, {}, 2),  # 35 s longer
        ({"time_min|M2|difficult": 4.1}, {}, 2),  # shorter: not "longer" at all
        ({"requests|M2|all/overall": 1.0}, {}, 3),  # more than slightly above M1
        ({"requests|M1|all/overall": 0.7, "requests|M1|abandon/overall": 0.03}, {}, 3),
        ({"requests|M1|decide/overall": 0.3}, {}, 4),
        ({"requests|M3|abandon/overall": 0.1}, {}, 5),  # 7.5% of M3's requests
    ],
)
def test_each_of_the_studys_words_fails_when_its_numbers_turn(changes, alone, broken) -> None:
    made = study_claims.claims(_study_means(**changes), study_claims.STUDY_ALONE | alone)
    assert [i for i, c in enumerate(made) if not c.met] == [broken]
    assert f"| {made[broken].words} | NO |" in study_claims.claims_markdown(made)


def _pool(people: int, seed: int) -> list[dict]:
    """Decision rows of `people` participants, one trial per model, 6 easy and 6 difficult
    decisions each; a person's own pace scales all their times (decisions cluster)."""
    rng = np.random.default_rng(seed)
    base = {"M1": (2.1, 4.2), "M2": (2.95, 4.6), "M3": (4.7, 6.2)}
    rows = []
    for p in range(people):
        pace = float(rng.lognormal(0.0, 0.2))
        for model, (easy, difficult) in base.items():
            for i in range(12):
                split = "easy" if i % 2 == 0 else "difficult"
                minutes = pace * (easy if split == "easy" else difficult) * rng.lognormal(0, 0.3)
                rows.append({
                    "participant": f"p{p}", "trial_id": f"p{p}-{model}", "model": model,
                    "collective": "I", "decision_index": i, "difficulty": split,
                    "correct": bool(rng.random() < 0.8), "start_s": 0.0, "end_s": 60 * minutes,
                    "decision_time_s": 60.0 * minutes, "n_investigate": int(rng.poisson(2)),
                    "n_decide": int(rng.poisson(1 if model == "M3" else 0.4)),
                    "n_abandon": int(rng.poisson(0.2)), "n_interventions": 0,
                })  # fmt: skip
    return rows


def _reproduction(rows: list[dict], alone: list[dict], *args, **kwargs) -> dict:
    """`study_claims.reproduction` of a pool of decision rows, as `hcss plan` calls it."""
    by_trial = teams.values_by_trial(rows, [], [], [])
    people = {r["trial_id"]: r["participant"] for r in rows}
    return study_claims.reproduction(by_trial, people, alone, *args, **kwargs)


def _chance_by_normal_theory(rows: list[dict], n: int) -> float:
    """The chance that M2's easy mean time exceeds M1's by more than a minute in a draw of
    n participants with replacement, by the delta method for the two ratio means (each
    person's time sum over their decision count), their covariance included: computed
    from the person-level totals, apart from the resampling it checks."""
    people = sorted({r["participant"] for r in rows})
    totals = {
        (model, p): [0.0, 0.0] for model in ("M1", "M2") for p in people
    }  # fmt: skip
    for r in rows:
        if r["model"] in ("M1", "M2") and r["difficulty"] == "easy":
            cell = totals[(r["model"], r["participant"])]
            cell[0] += r["decision_time_s"] / 60.0
            cell[1] += 1
    linear = []
    means = {}
    for model in ("M1", "M2"):
        sums = np.array([totals[(model, p)][0] for p in people])
        counts = np.array([totals[(model, p)][1] for p in people])
        means[model] = sums.sum() / counts.sum()
        linear.append((sums - means[model] * counts) / counts.mean())
    difference = linear[1] - linear[0]
    se = math.sqrt(float(difference.var(ddof=0)) / n)
    return float(norm.sf((1.0 - (means["M2"] - means["M1"])) / se))


def test_the_chance_a_study_bears_out_a_sentence_agrees_with_normal_theory() -> None:
    rows = _pool(60, seed=3)
    chances = _reproduction(rows, [], (10, 28), 4000, seed=1)
    for n in (10, 28):
        expected = _chance_by_normal_theory(rows, n)
        assert 0.2 < expected < 0.95  # a sentence near its edge: neither sure nor hopeless
        assert chances[n][1] == pytest.approx(expected, abs=0.04)
    assert math.isnan(chances[28][0])  # no collectives alone: not measured
    assert "| not measured |" in study_claims.reproduction_markdown(chances)


def test_large_studies_bear_out_what_the_pools_means_bear_out_with_room_and_no_more() -> None:
    """Teams at 80% success beside collectives alone at 25%, M3 deciding most: borne out by
    every study of 200; M2's requests, as many a decision as M1's over longer decisions,
    come less often a minute than M1's, so "least often with M1" by none."""
    rows = _pool(40, seed=4)
    alone = [
        {"model": m, "difficulty": s, "scenario_id": f"s{k}", "correct": k % 4 == 0}
        for m in ("M1", "M2")
        for s in ("easy", "difficult")
        for k in range(20)
    ]
    chances = _reproduction(rows, alone, (200,), 300, seed=2)[200]
    assert (chances[0], chances[3], chances[4]) == (1.0, 0.0, 1.0)


def test_a_trial_without_decisions_keeps_its_participant_in_the_resampling() -> None:
    """`hcss plan` names each trial's participant from every table: a trial whose
    collectives made no decision (its person never pushed) still has probe answers, so
    its participant is drawn, with those answers, like any other."""
    rows = TrialRows(decisions=_pool(2, seed=5))
    rows.probes.append({"participant": "p9", "trial_id": "p9-M3", "model": "M3", "level": 1})
    rows.observations.append({"participant": "p8", "trial_id": "p8-M1", "model": "M1"})
    named = rows.participant_of()
    assert named["p9-M3"] == "p9" and named["p8-M1"] == "p8"
    assert {named[r["trial_id"]] for r in rows.decisions} == {"p0", "p1"}
