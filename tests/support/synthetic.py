"""Synthetic exports written to the data dictionary (docs/data-dictionary.md).

The tests generate tables with exactly the dictionary's columns, so they do
not depend on running a simulation or a study. Values are
random but plausible; the tests that check numbers use the tiny hand-built
export in test_measures.py instead.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from hcss.simulation.decisions import DECISION_COLUMNS as SIMULATION_DECISION_COLUMNS
from hcss.tablespec.decisions import EXPORT_IDENTITY

DECISION_COLUMNS = list(SIMULATION_DECISION_COLUMNS)  # the contract, from its one definition
COLLECTIVES = ["I", "II", "III", "IV"]


def write_table(frame: pd.DataFrame, path: Path) -> Path:
    """CSV as the dictionary says: booleans as true/false, empty for missing."""
    out = frame.copy()
    for column in out.columns:
        if out[column].dtype == bool or str(out[column].dtype) == "boolean":
            out[column] = out[column].map({True: "true", False: "false"})
    path.parent.mkdir(parents=True, exist_ok=True)
    out.to_csv(path, index=False)
    return path


def decision_row(**values) -> dict:
    """One decision with every dictionary column, defaults filled in."""
    row = {
        "source": "study",
        "model": "M1",
        "participant": "",
        "trial_id": "t",
        "scenario_id": "s",
        "run": 0,
        "seed": 1,
        "first_section": "easy",
        "section": 1,
        "section_kind": "easy",
        "collective": "I",
        "decision_index": 1,
        "difficulty": "easy",
        "start_s": 0.0,
        "end_s": 60.0,
        "decision_time_s": 60.0,
        "timed_out": False,
        "chosen_target": 1,
        "chosen_value": 1.0,
        "chosen_distance_m": 150.0,
        "best_target": 1,
        "best_value": 1.0,
        "correct": True,
        "n_requests": 0,
        "n_investigate": 0,
        "n_abandon": 0,
        "n_decide": 0,
        "n_interventions": 0,
    }
    unknown = set(values) - set(row)
    assert not unknown, unknown
    row.update(values)
    time = values.get("decision_time_s")
    if "end_s" not in values and isinstance(time, int | float) and not isinstance(time, bool):
        row["end_s"] = row["start_s"] + time  # the loader checks end − start = time
    return row


def numbered(rows: list[dict]) -> list[dict]:
    """The rows with decision_index counted 1, 2, ... per trial and collective, in order: one
    key per decision, as the loader requires."""
    seen: dict[tuple, int] = {}
    for row in rows:
        key = (row["source"], row["trial_id"], row["collective"])
        seen[key] = seen.get(key, 0) + 1
        row["decision_index"] = seen[key]
    return rows


def stored_record(**values) -> dict:
    """A decision as a study stores it (`DecisionRow.record`): a decision_row without the
    export's who and where (hcss.tablespec.decisions.EXPORT_IDENTITY)."""
    return {
        name: value for name, value in decision_row(**values).items() if name not in EXPORT_IDENTITY
    }


def trial_rows(participant: str, model: str, seconds: list[float]) -> list[dict]:
    """One study trial's decisions, one per decision time (seconds) given."""
    return [
        decision_row(
            participant=participant,
            model=model,
            trial_id=f"{participant}-{model}",
            decision_index=index + 1,
            decision_time_s=float(value),
        )
        for index, value in enumerate(seconds)
    ]


def _trial_decisions(rng, source, model, participant, trial_id, scenario_id, run, human):
    """Twelve decisions of one trial, six per section, success depending on model."""
    success = {"M1": (0.9, 0.3), "M2": (0.9, 0.7), "M3": (0.8, 0.6)}[model]
    mean_minutes = {"M1": 4.0, "M2": 6.0, "M3": 5.0}[model]
    rows, clock = [], {c: 0.0 for c in COLLECTIVES}
    made = {c: 0 for c in COLLECTIVES}  # decisions per collective: the decision_index
    for section, kind in ((1, "easy"), (2, "difficult")):
        for index in range(6):
            collective = COLLECTIVES[index % 4]
            difficulty = (
                kind if rng.random() < 0.75 else ("easy" if kind == "difficult" else "difficult")
            )
            minutes = float(rng.gamma(4.0, mean_minutes / 4.0))
            correct = bool(rng.random() < success[0 if difficulty == "easy" else 1])
            investigate = int(rng.poisson(2)) if human else 0
            abandon = int(rng.poisson(0.5)) if human else 0
            decide = int(rng.poisson(0.7)) if human else 0
            start = clock[collective]
            clock[collective] = start + minutes * 60
            made[collective] += 1
            rows.append(
                decision_row(
                    source=source,
                    model=model,
                    participant=participant,
                    trial_id=trial_id,
                    scenario_id=scenario_id,
                    run=run,
                    seed=1000 + run,
                    section=section,
                    section_kind=kind,
                    collective=collective,
                    decision_index=made[collective],
                    difficulty=difficulty,
                    start_s=start,
                    end_s=start + minutes * 60,
                    decision_time_s=minutes * 60,
                    chosen_value=1.0 if correct else 0.8,
                    correct=correct,
                    n_requests=investigate + abandon + decide,
                    n_investigate=investigate,
                    n_abandon=abandon,
                    n_decide=decide,
                    n_interventions=int(rng.binomial(abandon, 0.5)),
                )
            )
    return rows


def simulation_decisions(scenarios: int = 6, runs: int = 3, seed: int = 7) -> pd.DataFrame:
    """A simulation-only experiment: M1 and M2 on the same scenarios, several runs each."""
    rng = np.random.default_rng(seed)
    rows = []
    for model in ("M1", "M2"):
        for scenario in range(scenarios):
            for run in range(runs):
                rows += _trial_decisions(
                    rng,
                    "simulation",
                    model,
                    "",
                    f"{model}-s{scenario}-r{run}",
                    f"s{scenario}",
                    run,
                    False,
                )
    return pd.DataFrame(rows, columns=DECISION_COLUMNS)


def study_export(directory: Path, participants: int = 6, seed: int = 11) -> Path:
    """A full study export: every table, real participants plus one bot and one pilot."""
    rng = np.random.default_rng(seed)
    codes = [f"P{number:02d}" for number in range(participants)] + ["BOT1", "PILOT1"]
    decisions, requests, observations, probes, items, scores, timings = ([] for _ in range(7))
    people = []
    for position, code in enumerate(codes):
        people.append(
            {
                "participant": code,
                "study": "original",
                "cell": position % 8 + 1,
                "model_order": "M1,M2,M3" if position % 8 < 4 else "M2,M1,M3",
                "is_pilot": code.startswith("PILOT"),
                "is_bot": code.startswith("BOT"),
                "is_demo": False,
                "status": "completed",
                "age_band": "18-30",
                "gender": "x",
                "education": "bachelor",
                "colour_vision": "no",
                "video_games": 3,
                "robots": 2,
                "mrt_score": int(rng.integers(4, 24)),
                "tlx_overall_M1": 50.0,
                "tlx_overall_M2": 50.0,
                "tlx_overall_M3": 50.0,
                "sart_M1": 5.0,
                "sart_M2": 5.0,
                "sart_M3": 5.0,
            }
        )
        total = people[-1]["mrt_score"]
        for scale, score in (
            ("total", total),
            ("part_1", total // 2),
            ("part_2", total - total // 2),
        ):
            # the export's MRT rows: the total, then each part (the last row is a half)
            scores.append(
                {
                    "participant": code,
                    "instrument": "mrt",
                    "model": "",
                    "scale": scale,
                    "score": score,
                }
            )
        for stage_index, stage in enumerate(("consent", "demographics", "mrt")):
            timings.append(
                {
                    "participant": code,
                    "stage_index": stage_index,
                    "stage": stage,
                    "model": "",
                    "entered_at": "2026-01-01T10:00:00Z",
                    "submitted_at": "2026-01-01T10:01:00Z",
                    "timed_out": False,
                }
            )
        for model in ("M1", "M2", "M3"):
            trial_id = f"{code}-{model}"
            trial = _trial_decisions(rng, "study", model, code, trial_id, f"sc-{model}", 0, True)
            decisions += trial
            for decision in trial:
                for kind in ("investigate", "abandon", "decide"):
                    for _ in range(decision[f"n_{kind}"]):
                        support = float(rng.uniform(0, 0.5))
                        requests.append(
                            {
                                "participant": code,
                                "trial_id": trial_id,
                                "model": model,
                                "sim_time_s": decision["start_s"] + 10,
                                "wall_time": "2026-01-01T10:10:00Z",
                                "request_id": len(requests),
                                "kind": kind,
                                "collective": decision["collective"],
                                "target": 1,
                                "accepted": True,
                                "reason": "",
                                "support": support,
                                "intervention": kind == "abandon" and support >= 0.1,
                                "decision_index": decision["decision_index"],
                            }
                        )
            for _ in range(int(rng.integers(5, 30))):
                kind = "collective" if rng.random() < 0.6 else "target"
                observations.append(
                    {
                        "participant": code,
                        "trial_id": trial_id,
                        "model": model,
                        "sim_time_s": 100.0,
                        "wall_time": "2026-01-01T10:10:00Z",
                        "kind": kind,
                        "collective": "I" if kind == "collective" else "",
                        "target": "" if kind == "collective" else 2,
                        "button": "left",
                    }
                )
            for index, level in enumerate([1] * 4 + [2] * 5 + [3] * 3):
                answered = rng.random() < 0.9
                probes.append(
                    {
                        "participant": code,
                        "trial_id": trial_id,
                        "model": model,
                        "sim_time_s": 60.0 * index,
                        "wall_time": "2026-01-01T10:10:00Z",
                        "probe_index": index + 1,
                        "level": level,
                        "question": "Which collective?",
                        "ready_latency_ms": 1000.0,
                        "answer_latency_ms": 2000.0 if answered else None,
                        "answer": "I" if answered else "",
                        "truth": "I",
                        "correct": bool(rng.random() < 0.7) if answered else None,
                        "timed_out": not answered,
                    }
                )
            components = [
                "mental_demand",
                "physical_demand",
                "temporal_demand",
                "performance",
                "effort",
                "frustration",
            ]
            for component in components:
                items.append(
                    {
                        "participant": code,
                        "wall_time": "2026-01-01T10:30:00Z",
                        "instrument": "nasa_tlx",
                        "model": model,
                        "item": component,
                        "value": str(int(rng.integers(0, 21)) * 5),
                    }
                )
                scores.append(
                    {
                        "participant": code,
                        "instrument": "nasa_tlx",
                        "model": model,
                        "scale": f"{component}_weighted",
                        "score": float(rng.uniform(0, 30)),
                    }
                )
            scores.append(
                {
                    "participant": code,
                    "instrument": "nasa_tlx",
                    "model": model,
                    "scale": "overall",
                    "score": float(rng.uniform(20, 80)),
                }
            )
            for scale in ("SU", "DAR", "SAR", "overall"):
                scores.append(
                    {
                        "participant": code,
                        "instrument": "sart",
                        "model": model,
                        "scale": scale,
                        "score": float(rng.integers(1, 8)),
                    }
                )
            for item in (
                "investigate_effectiveness",
                "abandon_effectiveness",
                "decide_effectiveness",
                "responsiveness",
                "performance",
                "understanding",
            ):
                items.append(
                    {
                        "participant": code,
                        "wall_time": "2026-01-01T10:31:00Z",
                        "instrument": "post_trial",
                        "model": model,
                        "item": item,
                        "value": str(int(rng.integers(1, 8))),
                    }
                )
        for scale in ("responsiveness", "performance", "comprehension"):
            for rank, model in enumerate(rng.permutation(["M1", "M2", "M3"]), start=1):
                scores.append(
                    {
                        "participant": code,
                        "instrument": "ranking",
                        "model": model,
                        "scale": scale,
                        "score": float(rank),
                    }
                )
    directory.mkdir(parents=True, exist_ok=True)
    write_table(pd.DataFrame(decisions, columns=DECISION_COLUMNS), directory / "decisions.csv")
    for name, rows in (
        ("requests", requests),
        ("observations", observations),
        ("probes", probes),
        ("questionnaire_items", items),
        ("scores", scores),
        ("participants", people),
        ("stage_timings", timings),
    ):
        write_table(pd.DataFrame(rows), directory / f"{name}.csv")
    return directory


#: Eight participants × three models; row 2 ties M2 and M3 (a zero difference).
SCORES = pd.DataFrame(
    [
        [50, 75, 60],
        [40, 70, 70],
        [55, 80, 65],
        [30, 60, 45],
        [60, 55, 70],
        [45, 90, 50],
        [35, 65, 40],
        [50, 85, 75],
    ],
    columns=["M1", "M2", "M3"],
)
