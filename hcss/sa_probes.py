"""SA probes filled from what the interface shows: shared by the live platform and the in-process synthetic trials.

`hcss.questionnaires.probes` words the questions and draws when each level is
asked; this module scales the study's 4/5/3 split to the trial length and,
at the moment a probe is due, picks a subject that makes sense then from
what the participant sees (`Simulation.display()`) and takes the truth from
the simulation's separate accessor (`Simulation.truth()`). The schedule uses its own generator,
never the simulation's, so probes do not perturb the deterministic replay.

It lives beside the model and the instruments, not in either (they know nothing of
each other): the platform's recorder (`hcss.platform.live.probes`) and the
synthetic operator's in-process trials (`hcss.experiments.synthetic_trials`) ask
the same probes from the same plan.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from hcss.questionnaires.probes import (
    DEFAULT_COUNTS,
    TEMPLATES,
    ProbeLevel,
    ScheduledProbe,
    draw_schedule,
)
from hcss.simulation import Display, Truth
from hcss.simulation.messages import collective_name, collective_names

POSTPONE_S = 10.0  # no sensible subject yet: look again this much later
STUDY_TRIAL_S = 1200.0  # DEFAULT_COUNTS are per 20-minute trial


@dataclass(frozen=True)
class FilledProbe:
    level: int
    question: str
    choices: list[str]
    truth: str | None  # None for level 3: scored when the next decision happens


def level_counts(
    duration_s: float, per_20_minutes: Mapping[ProbeLevel, int] | None = None
) -> dict[ProbeLevel, int]:
    """The study's split (`[probes]`, default 4/5/3) scaled to the trial length.

    At least one probe, unless the study asks for none at all.
    """
    wanted = DEFAULT_COUNTS if per_20_minutes is None else per_20_minutes
    per_trial = sum(wanted.values())
    if per_trial == 0:
        return dict.fromkeys(ProbeLevel, 0)
    total = max(1, round(per_trial * duration_s / STUDY_TRIAL_S))
    counts = {level: round(total * wanted.get(level, 0) / per_trial) for level in ProbeLevel}
    counts[ProbeLevel.COMPREHENSION] = max(
        0, total - counts[ProbeLevel.PERCEPTION] - counts[ProbeLevel.PROJECTION]
    )
    return counts


def probe_plan(
    seed: int, duration_s: float, per_20_minutes: Mapping[ProbeLevel, int] | None = None
) -> list[ScheduledProbe]:
    """The trial's probes; fewer when the trial is too short to keep them a time-out apart."""
    rng = np.random.default_rng([seed, 0x5A])  # a stream apart from the simulation's
    counts = level_counts(duration_s, per_20_minutes)
    while sum(counts.values()) > 0:
        try:
            return list(draw_schedule(rng, duration_s, counts))
        except ValueError:
            largest = max(counts, key=lambda level: counts[level])
            counts[largest] -= 1
    return []


def fill_probe(level: int, display: Display, truth: Truth, rng: np.random.Generator):
    """The probe for this moment, or None when no subject makes sense yet.

    Subjects come from what the participant sees (`display`); the level-2
    answer is scored against `truth` (`Simulation.truth()`), never shown.
    """
    template = TEMPLATES[ProbeLevel(level)]
    names = collective_names(display.n_collectives)
    drawn = np.flatnonzero(display.drawn)
    if level == ProbeLevel.PERCEPTION:
        supported = drawn[display.support[:, drawn].max(axis=0, initial=0.0) > 0]
        if not supported.size:
            return None
        column = int(supported[int(rng.integers(supported.size))])
        leader = int(np.argmax(display.support[:, column]))
        target = int(display.target_ids[column])
        return FilledProbe(level, template.fill(target), names, collective_name(leader))
    if level == ProbeLevel.COMPREHENSION:
        candidates = []
        for c in range(display.n_collectives):
            if display.executing[c]:
                continue
            best = truth.best_for(c)
            in_range = display.target_ids[drawn[display.in_range[c, drawn]]].tolist()
            if best is not None and best in in_range and len(in_range) >= 2:
                candidates.append((c, best, in_range))
        if not candidates:
            return None
        collective, best, in_range = candidates[int(rng.integers(len(candidates)))]
        choices = list(template.answer_choices(names, in_range))
        return FilledProbe(level, template.fill(collective_name(collective)), choices, str(best))
    return FilledProbe(level, template.fill(), names, None)
