"""Filling SA probes from the live state, on the questionnaire's templates and schedule.

`hcss.questionnaires.probes` words the questions and draws when each level is
asked; this module scales the study's 4/5/3 split to the trial length and,
at the moment a probe is due, picks a subject that makes sense then from
what the participant sees (`Simulation.display()`) and takes the truth from
the simulation's separate accessor (`Simulation.truth()`). The schedule uses its own generator,
never the simulation's, so probes do not perturb the deterministic replay.
The filling and the plan live in `hcss.sa_probes`, shared with the synthetic
operator's in-process trials; this module adds what only the platform needs.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from hcss.questionnaires.probes import PROBE_TIMEOUT_S, TEMPLATES, ProbeLevel
from hcss.sa_probes import (
    POSTPONE_S,
    STUDY_TRIAL_S,
    FilledProbe,
    fill_probe,
    level_counts,
    probe_plan,
)
from hcss.simulation.messages import collective_names

__all__ = [
    "POSTPONE_S",
    "PROBE_TIMEOUT_S",
    "STUDY_TRIAL_S",
    "FilledProbe",
    "fill_probe",
    "level_counts",
    "probe_plan",
    "probe_subject",
    "stored_counts",
]


def probe_subject(level: int, question: str) -> dict[str, int] | None:
    """What a question asks about, so a page can keep the probe box off it.

    {"collective": index} or {"target": id}, read back from the stored wording
    (the live page and the replay both show it); None for a question about
    all collectives.
    """
    template = TEMPLATES[ProbeLevel(level)]
    value = template.subject(question)
    if value is None:
        return None
    if template.slot == "collective":
        names = collective_names()
        return {"collective": names.index(value)} if value in names else None
    return {"target": int(value)} if value.isdecimal() else None


def stored_counts(counts: Mapping[int, int] | None) -> dict[str, int] | None:
    """The study's `[probes]` as the trial row stores them (JSON keys are strings)."""
    return None if counts is None else {str(int(level)): int(n) for level, n in counts.items()}


def counts_of(stored: Mapping[str, Any] | None) -> dict[ProbeLevel, int] | None:
    """The trial row's probe counts back as levels; None: the original protocol's."""
    if stored is None:
        return None
    return {ProbeLevel(int(level)): int(n) for level, n in stored.items()}
