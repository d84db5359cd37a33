"""Every measure's definition, checked by hand on a tiny export.

The export below is small enough to compute each expected value on paper;
the arithmetic is written next to each assertion.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest

from hcss.analysis.comparisons import correlations
from hcss.analysis.load import load_inputs
from hcss.analysis.measures import all_measures, measure_label
from tests.support.synthetic import (
    DECISION_COLUMNS,
    decision_row,
    numbered,
    study_export,
    write_table,
)


def _study_decisions() -> list[dict]:
    p1 = {"source": "study", "model": "M1", "participant": "P1", "trial_id": "T1"}
    p2 = {"source": "study", "model": "M1", "participant": "P2", "trial_id": "T2"}
    bot = {"source": "study", "model": "M1", "participant": "BOT", "trial_id": "T3"}
    return [
        # P1: easy 2 min correct; difficult 4 min wrong; difficult timed out at 30 min
        decision_row(
            **p1,
            difficulty="easy",
            decision_time_s=120.0,
            correct=True,
            n_requests=4,
            n_investigate=2,
            n_abandon=1,
            n_decide=1,
            n_interventions=1,
        ),
        decision_row(
            **p1,
            difficulty="difficult",
            decision_time_s=240.0,
            correct=False,
            n_requests=2,
            n_investigate=2,
        ),
        decision_row(
            **p1, difficulty="difficult", decision_time_s=1800.0, correct=False, timed_out=True
        ),
        # P2: a single easy decision of 1 min with 3 investigates
        decision_row(
            **p2,
            difficulty="easy",
            decision_time_s=60.0,
            correct=True,
            n_requests=3,
            n_investigate=3,
        ),
        # BOT: excluded unless --include-pilot
        decision_row(**bot, difficulty="easy", decision_time_s=600.0, correct=False),
    ]


def _simulation_decisions() -> list[dict]:
    run0 = {
        "source": "simulation",
        "model": "M2",
        "scenario_id": "S1",
        "trial_id": "S1-0",
        "run": 0,
    }
    run1 = {
        "source": "simulation",
        "model": "M2",
        "scenario_id": "S1",
        "trial_id": "S1-1",
        "run": 1,
    }
    return [
        decision_row(**run0, difficulty="easy", decision_time_s=60.0, correct=True),
        decision_row(**run0, difficulty="easy", decision_time_s=180.0, correct=True),
        decision_row(**run1, difficulty="easy", decision_time_s=120.0, correct=True),
        decision_row(**run1, difficulty="difficult", decision_time_s=120.0, correct=False),
    ]


def _rows(participant: str, trial: str, count: int, **values) -> list[dict]:
    base = {
        "participant": participant,
        "trial_id": trial,
        "model": "M1",
        "sim_time_s": 1.0,
        "wall_time": "2026-01-01T10:00:00Z",
    }
    return [base | values for _ in range(count)]


@pytest.fixture()
def tiny_export(tmp_path: Path) -> Path:
    study = tmp_path / "study"
    write_table(
        pd.DataFrame(numbered(_study_decisions()), columns=DECISION_COLUMNS),
        study / "decisions.csv",
    )
    request = {
        "request_id": 1,
        "collective": "I",
        "target": 1,
        "reason": "",
        "support": 0.2,
        "decision_index": 1,
    }
    requests = (
        _rows("P1", "T1", 6, **request, kind="investigate", accepted=True, intervention=False)
        + _rows(
            "P1",
            "T1",
            1,
            **request | {"reason": "out of range"},
            kind="decide",
            accepted=False,
            intervention=False,
        )
        + _rows("BOT", "T3", 9, **request, kind="investigate", accepted=True, intervention=False)
    )
    write_table(pd.DataFrame(requests), study / "requests.csv")
    observations = (
        _rows("P1", "T1", 5, kind="collective", collective="I", target="", button="left")
        + _rows("P1", "T1", 3, kind="target", collective="", target=2, button="right")
        # P2 observed nothing and requested nothing in the log: no percentage at all
    )
    write_table(pd.DataFrame(observations), study / "observations.csv")
    probe = {
        "question": "q",
        "ready_latency_ms": 1000.0,
        "answer_latency_ms": 2000.0,
        "answer": "I",
        "truth": "I",
    }
    probes = []
    for level, correct, timed_out in [
        (1, True, False),
        (1, False, False),
        (1, None, True),  # level 1: 1 of 3
        (2, True, False),
        (2, True, False),  # level 2: 2 of 2
        (3, None, False),
        (3, False, False),  # level 3: unscored left out, 0 of 1
    ]:
        probes += _rows("P1", "T1", 1, **probe, level=level, correct=correct, timed_out=timed_out)
    write_table(pd.DataFrame(probes).assign(probe_index=range(1, 8)), study / "probes.csv")
    scores = pd.DataFrame(
        [
            ("P1", "nasa_tlx", "M1", "overall", 40.0),
            ("P1", "nasa_tlx", "M1", "overall", 45.0),  # a correction: the later row wins
            ("P1", "nasa_tlx", "M1", "effort_weighted", 12.0),
            ("P1", "sart", "M1", "overall", 7.0),
            ("P1", "ranking", "M1", "responsiveness", 2.0),
            # the export's MRT rows: the total and each part; the part's row comes last
            ("P1", "mrt", "", "total", 17.0),
            ("P1", "mrt", "", "part_1", 9.0),
            ("P1", "mrt", "", "part_2", 8.0),
            ("P2", "mrt", "", "part_1", 4.0),  # no total row: the parts are summed
            ("P2", "mrt", "", "part_2", 5.0),
        ],
        columns=["participant", "instrument", "model", "scale", "score"],
    )
    write_table(scores, study / "scores.csv")
    items = pd.DataFrame(
        [
            ("P1", "2026-01-01T10:00:00Z", "post_trial", "M1", "responsiveness", "5"),
            ("P2", "2026-01-01T10:00:00Z", "post_trial", "M1", "responsiveness", "3"),
        ],
        columns=["participant", "wall_time", "instrument", "model", "item", "value"],
    )
    write_table(items, study / "questionnaire_items.csv")
    participants = pd.DataFrame(
        [
            ("P1", False, False, False, 17),
            ("P2", False, False, False, 9),
            ("BOT", False, True, False, 0),
        ],
        columns=["participant", "is_pilot", "is_bot", "is_demo", "mrt_score"],
    )
    write_table(participants, study / "participants.csv")
    write_table(
        pd.DataFrame(numbered(_simulation_decisions()), columns=DECISION_COLUMNS),
        tmp_path / "simulation.csv",
    )
    return tmp_path


@pytest.fixture()
def measures(tiny_export: Path) -> pd.DataFrame:
    tables = load_inputs([tiny_export / "study", tiny_export / "simulation.csv"])
    return all_measures(tables)


def value(measures, measure, unit, split="overall"):
    found = measures[
        (measures["measure"] == measure) & (measures["unit"] == unit) & (measures["split"] == split)
    ]
    assert len(found) == 1, (measure, unit, split, found)
    return found["value"].iloc[0]


def test_success_rate_counts_timeouts_as_incorrect(measures):
    assert value(measures, "success_rate", "P1") == pytest.approx(1 / 3)
    assert value(measures, "success_rate", "P1", "easy") == 1.0
    assert value(measures, "success_rate", "P1", "difficult") == 0.0


def test_simulation_success_rate_is_mean_over_runs_of_the_scenario(measures):
    # run 0: 2/2 = 1.0, run 1: 1/2 = 0.5 -> scenario S1: 0.75
    assert value(measures, "success_rate", "S1") == pytest.approx(0.75)
    # easy: run 0 1.0, run 1 1.0; difficult exists only in run 1: 0.0
    assert value(measures, "success_rate", "S1", "easy") == 1.0
    assert value(measures, "success_rate", "S1", "difficult") == 0.0
    s1 = measures[measures["unit"] == "S1"]
    assert set(s1["group"]) == {"M2SIM"}
    # no operator in a simulation: no request measures for it
    assert set(s1["measure"]) == {"success_rate", "decision_time_min"}


def test_decision_time_in_minutes(measures):
    assert value(measures, "decision_time_min", "P1") == pytest.approx((2 + 4 + 30) / 3)
    assert value(measures, "decision_time_min", "P1", "difficult") == pytest.approx(17.0)
    # S1: run 0 (1 + 3) / 2 = 2, run 1 (2 + 2) / 2 = 2
    assert value(measures, "decision_time_min", "S1") == pytest.approx(2.0)


def test_request_frequencies_per_decision_per_minute(measures):
    # per decision: 4/2 = 2, 2/4 = 0.5, 0/30 = 0 -> mean 2.5/3
    assert value(measures, "request_frequency", "P1") == pytest.approx(2.5 / 3)
    assert value(measures, "request_frequency", "P1", "easy") == pytest.approx(2.0)
    assert value(measures, "request_frequency", "P1", "difficult") == pytest.approx(0.25)
    # investigate 2/2 = 1, 2/4 = 0.5, 0 -> 0.5; abandon and decide 1/2, 0, 0 -> 1/6
    assert value(measures, "investigate_frequency", "P1") == pytest.approx(0.5)
    assert value(measures, "abandon_frequency", "P1") == pytest.approx(1 / 6)
    assert value(measures, "decide_frequency", "P1") == pytest.approx(1 / 6)
    assert value(measures, "investigate_frequency", "P2") == pytest.approx(3.0)


def test_interventions_are_summed_per_participant(measures):
    assert value(measures, "interventions", "P1") == 1
    assert value(measures, "interventions", "P1", "easy") == 1
    assert value(measures, "interventions", "P1", "difficult") == 0


def test_observations_as_percentage_of_all_actions(measures):
    # 7 requests (one refused, still an action) + 8 observations = 15 actions
    assert value(measures, "collective_observations", "P1") == pytest.approx(100 * 5 / 15)
    assert value(measures, "target_observations", "P1") == pytest.approx(100 * 3 / 15)
    # P2 took no logged action: no percentage rather than a fake 0
    assert not ((measures["unit"] == "P2") & (measures["measure"] == "target_observations")).any()
    # observations are per trial, not split by difficulty
    assert set(measures[measures["measure"] == "target_observations"]["split"]) == {"overall"}


def test_sa_probe_percent_correct(measures):
    # 6 scored probes (the unscored level-3 probe is left out), 3 correct
    assert value(measures, "sa_overall", "P1") == pytest.approx(50.0)
    assert value(measures, "sa_level1", "P1") == pytest.approx(100 / 3)  # time-out is wrong
    assert value(measures, "sa_level2", "P1") == pytest.approx(100.0)
    assert value(measures, "sa_level3", "P1") == pytest.approx(0.0)


def test_questionnaires_from_scores_and_items(measures):
    assert value(measures, "nasa_tlx.overall", "P1") == 45.0  # the correction wins
    assert value(measures, "nasa_tlx.effort_weighted", "P1") == 12.0
    assert value(measures, "sart.overall", "P1") == 7.0
    assert value(measures, "ranking.responsiveness", "P1") == 2.0
    # no post_trial scores in this export: the raw Likert items are used
    assert value(measures, "post_trial.responsiveness", "P2") == 3.0
    assert value(measures, "mrt.total", "P1") == 17.0


def test_the_mrt_score_is_the_whole_test_one_row_per_participant(measures):
    mrt = measures[measures["measure"].str.startswith("mrt.")]
    assert set(mrt["measure"]) == {"mrt.total"}  # never a part, never a second "overall"
    assert sorted(mrt["participant"]) == ["P1", "P2"]
    assert value(measures, "mrt.total", "P1") == 17.0  # not part 2's 8
    assert value(measures, "mrt.total", "P2") == 9.0  # 4 + 5
    assert measure_label("mrt.total") == "MRT score: items right over the study's timed parts"
    assert measure_label("nasa_tlx.effort_weighted") == "NASA-TLX: effort weighted"


def test_bot_participants_are_excluded_unless_asked(tiny_export):
    default = all_measures(load_inputs([tiny_export / "study"]))
    assert "BOT" not in set(default["unit"])
    included = all_measures(load_inputs([tiny_export / "study"], include_pilot=True))
    assert value(included, "success_rate", "BOT") == 0.0
    # nor does its trial reach any other measure
    assert "BOT" not in set(default[default["measure"] == "request_frequency"]["unit"])


def test_the_mrt_correlation_uses_the_total_as_r_does(tmp_path):
    """The export's last MRT row is part 2, which the correlation used (ρ −0.372, p .364).

    R 4.2, the 8 participants' MRT totals and M1 success rates of this export:
    mrt <- c(6, 10, 4, 11, 18, 10, 15, 17); s <- c(10, 4, 9, 9, 7, 9, 6, 9) / 12
    cor.test(mrt, s, method = "spearman")   # rho -0.4019348353313, p 0.3236049344748
    cor.test(mrt - mrt %/% 2, s, method = "spearman")   # part 2: -0.3722847203232, 0.3637808929652
    """
    tables = load_inputs([study_export(tmp_path / "export", participants=8)])
    measures = all_measures(tables)
    totals = measures[measures["measure"] == "mrt.total"].set_index("participant")["value"]
    assert totals.tolist() == [6, 10, 4, 11, 18, 10, 15, 17]
    (m1,) = [c for c in correlations(measures) if c.x == "mrt.total" and c.group == "M1"]
    assert m1.result.statistic == pytest.approx(-0.4019348353313, rel=1e-9)
    assert m1.result.p == pytest.approx(0.3236049344748, rel=1e-9)


def test_the_mrt_range_is_each_studys_own() -> None:
    """The export names each participant's MRT parts; the report's range is per study,
    never the original's 0–24 for a demo of one part of 4."""
    from hcss.analysis.instrument_measures import mrt_range_note

    participants = pd.DataFrame(
        {
            "participant": ["P1", "P2", "P3", "P4"],
            "study": ["demo", "demo", "original", "original"],
            "mrt_part_items": ["4", "4", "12,12", None],
        }
    )
    assert mrt_range_note(participants.iloc[:2]) == (
        "MRT score range: 0–4 in demo (one timed part of 4 items)."
    )
    assert mrt_range_note(participants) == (
        "MRT score range: 0–4 in demo (one timed part of 4 items); "
        "0–24 in original (2 timed parts of 12 items)."
    )
    older = participants.drop(columns=["mrt_part_items"])  # an export from before the column
    assert mrt_range_note(older) == ""
