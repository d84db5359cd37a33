"""The study's words about its operators (§11's closing paragraph), read on teams' rows.

They are held back from the calibration, which fits each of §11's cells on its
own: how one model's cells stand beside another's is not fitted, so these
sentences validate the operator (the study's Kruskal-Wallis, Tukey-Kramer and
correlation values, which the issue also holds back, are not in §11). `hcss
plan` reads them on its predicted teams, and gives the chance that a study of N
participants bears each one out (`reproduction`), by the same resampling of
participants as its power.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from hcss.experiments import study_teams as teams
from hcss.experiments.study_targets import STUDY_TARGETS

#: §10's collectives alone, success per decision (%) by (model, split): what the study's
#: operators improved on.
STUDY_ALONE: dict[tuple[str, str], float] = {
    (t.model, t.split): t.success_pct for t in STUDY_TARGETS
}


@dataclass(frozen=True)
class Claim:
    """One of the study's sentences about its operators, and whether teams' rows bear it out."""

    words: str
    met: bool | None  # None: not measured on these rows
    measured: str


_IMPROVED = "operators improved both models' success (M1's and M2's, easy and difficult)"
_EASY = "with M2 they took more than a minute longer on easy decisions than with M1"
_DIFFICULT = "with M2 they took less than 30 s longer on difficult decisions than with M1"
_REQUESTS = "they issued requests least often with M1, slightly more with M2 and most with M3"
_DECIDES = "decide requests were most frequent with M3"
_INTERVENTIONS = "with M1 the operator's few requests were more often interventions"
#: The sentences, in the order `claims` reads them (and the plan's tables print them).
SENTENCES = (_IMPROVED, _EASY, _DIFFICULT, _REQUESTS, _DECIDES, _INTERVENTIONS)


def claims(
    measured: Mapping[tuple[str, str, str], teams.Measured],
    alone: Mapping[tuple[str, str], float] | None = None,
) -> list[Claim]:
    """The study's words about its operators (§11's closing paragraph), read on teams' cells.

    They are held back from the fit: it fits each cell's mean, not how one model's
    cells stand beside another's, so they validate the operator. `alone` is the
    collectives' success without an operator by (model, split) (`study_targets.measure`
    of simulation-only rows); without it the first sentence is not measured. Each
    sentence is coded as the study's own tables bear it out (`STUDY_ALONE` and §11's
    means meet every one). Not coded [choice]: "most on M2's difficult decisions" (the
    improvement from §10's collectives alone to §11's teams is largest on M1's difficult
    decisions, +49 points against M2's +17, so the tables do not carry the sentence).
    """

    def mean(measure: str, model: str, column: str) -> float:
        got = measured.get((measure, model, column))
        return got.mean if got is not None else math.nan

    out: list[Claim] = []
    if alone is None:
        out.append(Claim(_IMPROVED, None, "no collectives alone measured here"))
    else:
        gains = {
            (model, split): mean("success_pct", model, split) - alone.get((model, split), math.nan)
            for model in ("M1", "M2")
            for split in ("easy", "difficult")
        }
        shown = ", ".join(f"{m} {s} {g:+.1f}" for (m, s), g in gains.items())
        out.append(Claim(_IMPROVED, all(g > 0 for g in gains.values()), f"points: {shown}"))
    easy = mean("time_min", "M2", "easy") - mean("time_min", "M1", "easy")
    difficult = mean("time_min", "M2", "difficult") - mean("time_min", "M1", "difficult")
    out.append(
        Claim(
            _EASY,
            easy > 1.0,
            f"M2 - M1 easy {easy:+.2f} min",
        )
    )
    out.append(
        Claim(
            _DIFFICULT,
            0.0 <= difficult < 0.5,
            f"M2 - M1 difficult {difficult * 60:+.0f} s",
        )
    )
    every = [mean("requests", model, "all/overall") for model in teams.MODELS]
    out.append(
        Claim(
            _REQUESTS,
            every[0] < every[1] < every[2] and every[1] - every[0] < every[2] - every[1],
            "a minute: "
            + ", ".join(f"{m} {v:.2f}" for m, v in zip(teams.MODELS, every, strict=True)),
        )
    )
    decides = [mean("requests", model, "decide/overall") for model in teams.MODELS]
    out.append(
        Claim(
            _DECIDES,
            decides[2] > max(decides[:2]),
            "a minute: "
            + ", ".join(f"{m} {v:.2f}" for m, v in zip(teams.MODELS, decides, strict=True)),
        )
    )
    shares = [
        mean("requests", model, "abandon/overall") / mean("requests", model, "all/overall")
        for model in teams.MODELS
    ]
    out.append(
        Claim(
            _INTERVENTIONS,
            shares[0] > max(shares[1:]),
            "abandons of all requests: "
            + ", ".join(f"{m} {v:.0%}" for m, v in zip(teams.MODELS, shares, strict=True)),
        )
    )
    return out


def claims_markdown(claims_made: Iterable[Claim]) -> str:
    lines = ["| the study's words | met | measured |", "|---|---|---|"]
    for claim in claims_made:
        met = "not measured" if claim.met is None else ("yes" if claim.met else "NO")
        lines.append(f"| {claim.words} | {met} | {claim.measured} |")
    return "\n".join(lines)


def reproduction(
    by_trial: Mapping[tuple[str, str, str], Mapping[str, list[float]]],
    participant_of: Mapping[str, str],
    simulated: Iterable[Mapping[str, Any]],
    ns: Sequence[int],
    replications: int,
    seed: int,
) -> dict[int, list[float]]:
    """Per N: the share of `replications` studies of N participants (drawn with
    replacement from the pool, with all their trials) and N simulation-only scenarios
    (`simulated`, drawn the same way) whose means bear out each of `claims`' sentences.
    `by_trial` is the pool's cells as `study_teams.values_by_trial` groups them, and
    `participant_of` names each trial's participant.

    Why: a sentence the pool bears out may still fail in a study of 28 people (M2's
    extra time on difficult decisions is a difference of two noisy means); this is how
    often it would hold, as power is how often a test would reject.
    """
    people = sorted(set(participant_of.values()))
    column = {p: i for i, p in enumerate(people)}
    keys = list(by_trial)
    sums, counts = np.zeros((len(keys), len(people))), np.zeros((len(keys), len(people)))
    for k, key in enumerate(keys):
        for trial, values in by_trial[key].items():
            if trial in participant_of:
                sums[k, column[participant_of[trial]]] += math.fsum(values)
                counts[k, column[participant_of[trial]]] += len(values)
    alone_keys, alone_sums, alone_counts = _alone_by_scenario(simulated)
    rng = np.random.default_rng(seed)
    out: dict[int, list[float]] = {}
    for n in ns:
        met = np.zeros(len(SENTENCES), dtype=float)
        for _ in range(replications):
            drawn = rng.integers(len(people), size=n)
            with np.errstate(invalid="ignore", divide="ignore"):
                means = sums[:, drawn].sum(axis=1) / counts[:, drawn].sum(axis=1)
            measured = {
                key: teams.Measured(float(m), math.nan, n)
                for key, m in zip(keys, means, strict=True)
            }
            alone = None
            if alone_sums.size:
                scenarios = rng.integers(alone_sums.shape[1], size=n)
                with np.errstate(invalid="ignore", divide="ignore"):
                    rates = alone_sums[:, scenarios].sum(axis=1) / alone_counts[:, scenarios].sum(
                        axis=1
                    )
                alone = dict(zip(alone_keys, rates.tolist(), strict=True))
            met += [math.nan if c.met is None else float(c.met) for c in claims(measured, alone)]
        out[n] = (met / replications).tolist()  # NaN: a sentence these rows cannot measure
    return out


def _alone_by_scenario(
    simulated: Iterable[Mapping[str, Any]],
) -> tuple[list[tuple[str, str]], np.ndarray, np.ndarray]:
    """Collectives alone: per (model, split), success (%) summed and counted by scenario."""
    per: dict[tuple[str, str], dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for row in simulated:
        per[(str(row["model"]), str(row["difficulty"]))][str(row["scenario_id"])].append(
            100.0 * bool(row["correct"])
        )
    keys = sorted(per)
    scenarios = sorted({s for by in per.values() for s in by})
    sums = np.array([[math.fsum(per[k].get(s, [])) for s in scenarios] for k in keys])
    counts = np.array([[len(per[k].get(s, [])) for s in scenarios] for k in keys], dtype=float)
    return keys, sums.reshape(len(keys), len(scenarios)), counts.reshape(len(keys), len(scenarios))


def reproduction_markdown(chances: Mapping[int, Sequence[float]]) -> str:
    ns = sorted(chances)
    lines = [
        "| the study's words | " + " | ".join(f"N={n}" for n in ns) + " |",
        "|---|" + "---|" * len(ns),
    ]
    for i, words in enumerate(SENTENCES):
        lines.append(f"| {words} | " + " | ".join(_chance(chances[n][i]) for n in ns) + " |")
    return "\n".join(lines)


def _chance(value: float) -> str:
    return "not measured" if math.isnan(value) else f"{value:.2f}"
