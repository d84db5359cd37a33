"""Situation-awareness probe templates and a trial's probe schedule (SPAM style).

A probe asks about one of the three levels of situation awareness:
perception (what is happening), comprehension (what it means) and projection
(what will happen). The templates hold the wording with a slot; the live
platform fills the slot with a collective or target that makes sense at that
moment and takes the correct answer from the simulation. This module only
words the questions and decides when each level is asked.

Schedule: a trial's probes are spread evenly over its length, one per equal
slot, each jittered inside its slot, so probes come "about once a minute"
without being predictable and never overlap (the gap between two probes is
always longer than a probe's 30-second time-out).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import IntEnum, StrEnum

import numpy as np

PROBE_TIMEOUT_S = 30.0
#: Fraction of its slot by which a probe may move either way from the slot's centre.
JITTER_FRACTION = 0.25


class ProbeLevel(IntEnum):
    PERCEPTION = 1
    COMPREHENSION = 2
    PROJECTION = 3


class AnswerKind(StrEnum):
    COLLECTIVE = "collective"
    TARGET = "target"


@dataclass(frozen=True)
class ProbeTemplate:
    """A question with at most one slot, `{target}` or `{collective}`."""

    level: ProbeLevel
    text: str
    slot: str | None
    answer_kind: AnswerKind

    def fill(self, value: str | int | None = None) -> str:
        """The question as shown, e.g. fill(7) -> "Which collective is investigating target 7?"."""
        if self.slot is None:
            if value is not None:
                raise ValueError(f"level {self.level} probes take no {value!r}")
            return self.text
        if value is None or value == "":
            raise ValueError(f"level {self.level} probes need a {self.slot}")
        return self.text.format(**{self.slot: value})

    def subject(self, question: str) -> str | None:
        """The slot's value in a question this template worded (fill's inverse).

        The page keeps the probe box off the collective or target a question
        asks about, so it needs the subject apart from the wording; None for a
        question without a slot or one this template did not word.
        """
        if self.slot is None:
            return None
        head, _, tail = self.text.partition("{" + self.slot + "}")
        if not (question.startswith(head) and question.endswith(tail)):
            return None
        value = question[len(head) : len(question) - len(tail)]
        return value or None

    def answer_choices(self, collectives: Sequence[str], targets: Sequence[int]) -> tuple[str, ...]:
        """The options offered: the collectives I-IV, or the visible target ids."""
        if self.answer_kind is AnswerKind.COLLECTIVE:
            return tuple(collectives)
        return tuple(str(target) for target in sorted(targets))


TEMPLATES: Mapping[ProbeLevel, ProbeTemplate] = {
    ProbeLevel.PERCEPTION: ProbeTemplate(
        ProbeLevel.PERCEPTION,
        "Which collective is investigating target {target}?",
        "target",
        AnswerKind.COLLECTIVE,
    ),
    ProbeLevel.COMPREHENSION: ProbeTemplate(
        ProbeLevel.COMPREHENSION,
        "Which target is the best choice for collective {collective}?",
        "collective",
        AnswerKind.TARGET,
    ),
    ProbeLevel.PROJECTION: ProbeTemplate(
        ProbeLevel.PROJECTION,
        "Which collective will make the next decision?",
        None,
        AnswerKind.COLLECTIVE,
    ),
}

#: Probes per trial in the original protocol.
DEFAULT_COUNTS: Mapping[ProbeLevel, int] = {
    ProbeLevel.PERCEPTION: 4,
    ProbeLevel.COMPREHENSION: 5,
    ProbeLevel.PROJECTION: 3,
}


@dataclass(frozen=True)
class ScheduledProbe:
    """The `index`-th probe (1-based) of a trial, asked `at_s` seconds into it."""

    index: int
    level: ProbeLevel
    at_s: float

    @property
    def template(self) -> ProbeTemplate:
        return TEMPLATES[self.level]


def draw_schedule(
    rng: np.random.Generator,
    trial_length_s: float,
    counts: Mapping[ProbeLevel, int] = DEFAULT_COUNTS,
    jitter_fraction: float = JITTER_FRACTION,
) -> tuple[ScheduledProbe, ...]:
    """Times and levels of a trial's probes, levels in random order.

    Raises ValueError when the trial is too short for that many probes to be
    at least a time-out apart, rather than silently crowding them.
    """
    levels = [level for level in ProbeLevel for _ in range(counts.get(level, 0))]
    total = len(levels)
    if total == 0:
        return ()
    if not 0.0 <= jitter_fraction < 0.5:
        raise ValueError("jitter_fraction must be in [0, 0.5)")
    slot = trial_length_s / total
    if slot * (1.0 - 2.0 * jitter_fraction) <= PROBE_TIMEOUT_S:
        raise ValueError(
            f"{total} probes in {trial_length_s:g} s could come closer than the "
            f"{PROBE_TIMEOUT_S:g} s time-out; use fewer probes, less jitter or a longer trial"
        )
    order = rng.permutation(total)
    offsets = rng.uniform(-jitter_fraction, jitter_fraction, size=total) * slot
    return tuple(
        ScheduledProbe(
            index=position + 1,
            level=levels[int(order[position])],
            at_s=float((position + 0.5) * slot + offsets[position]),
        )
        for position in range(total)
    )
