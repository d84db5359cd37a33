"""SA probe wording and a trial's probe schedule."""

from __future__ import annotations

import numpy as np
import pytest

from hcss.questionnaires.probes import (
    PROBE_TIMEOUT_S,
    TEMPLATES,
    AnswerKind,
    ProbeLevel,
    draw_schedule,
)


def test_templates_fill_their_slot() -> None:
    assert TEMPLATES[ProbeLevel.PERCEPTION].fill(7) == "Which collective is investigating target 7?"
    assert (
        TEMPLATES[ProbeLevel.COMPREHENSION].fill("III")
        == "Which target is the best choice for collective III?"
    )
    assert (
        TEMPLATES[ProbeLevel.PROJECTION].fill() == "Which collective will make the next decision?"
    )
    with pytest.raises(ValueError):
        TEMPLATES[ProbeLevel.PERCEPTION].fill()
    with pytest.raises(ValueError):
        TEMPLATES[ProbeLevel.PROJECTION].fill("II")


def test_a_question_gives_back_its_subject() -> None:
    """The page keeps the probe box off the subject, read back from the stored question."""
    perception, comprehension = (
        TEMPLATES[ProbeLevel.PERCEPTION],
        TEMPLATES[ProbeLevel.COMPREHENSION],
    )
    assert perception.subject(perception.fill(17)) == "17"
    assert comprehension.subject(comprehension.fill("IV")) == "IV"
    assert TEMPLATES[ProbeLevel.PROJECTION].subject(TEMPLATES[ProbeLevel.PROJECTION].fill()) is None
    assert perception.subject(comprehension.fill("IV")) is None  # another template's words


def test_answer_choices_are_collectives_or_targets() -> None:
    collectives = ("I", "II", "III", "IV")
    perception = TEMPLATES[ProbeLevel.PERCEPTION]
    assert perception.answer_kind is AnswerKind.COLLECTIVE
    assert perception.answer_choices(collectives, [4, 2]) == collectives
    assert TEMPLATES[ProbeLevel.COMPREHENSION].answer_choices(collectives, [12, 3, 7]) == (
        "3",
        "7",
        "12",
    )


def test_default_schedule_of_a_twenty_minute_trial() -> None:
    schedule = draw_schedule(np.random.default_rng(2), 1200.0)
    levels = [probe.level for probe in schedule]
    assert levels.count(ProbeLevel.PERCEPTION) == 4
    assert levels.count(ProbeLevel.COMPREHENSION) == 5
    assert levels.count(ProbeLevel.PROJECTION) == 3
    assert [probe.index for probe in schedule] == list(range(1, 13))
    times = np.array([probe.at_s for probe in schedule])
    assert np.all(np.diff(times) > PROBE_TIMEOUT_S)
    assert times[0] > 0 and times[-1] < 1200.0
    assert 60.0 <= np.diff(times).mean() <= 120.0
    for slot, time in enumerate(times):
        assert 100.0 * slot <= time <= 100.0 * (slot + 1)


def test_schedules_are_reproducible_and_vary_between_seeds() -> None:
    def key(seed: int):
        return tuple(
            (p.level, round(p.at_s, 6)) for p in draw_schedule(np.random.default_rng(seed), 1200.0)
        )

    assert key(4) == key(4)
    assert len({key(seed) for seed in range(10)}) == 10
    orders = {
        tuple(p.level for p in draw_schedule(np.random.default_rng(s), 1200.0)) for s in range(30)
    }
    assert len(orders) > 20


def test_a_trial_too_short_for_its_probes_is_refused() -> None:
    with pytest.raises(ValueError, match="time-out"):
        draw_schedule(np.random.default_rng(0), 300.0)
    short = draw_schedule(
        np.random.default_rng(0), 300.0, counts={ProbeLevel.PERCEPTION: 1, ProbeLevel.PROJECTION: 2}
    )
    assert [p.index for p in short] == [1, 2, 3]
