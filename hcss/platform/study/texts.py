"""The study's texts made to fit its study file: durations, counts and design.

The Markdown texts (hcss/questionnaires/texts) say ``{{ trial_length }}``
where a number depends on the study; `fill` puts in the study file's values,
worded with correct plurals ("1 minute", "a 2-minute trial"), so a demo with
one-minute trainings never tells a participant about five-minute ones. The
debrief's sentence on the order of the types is written from the study's
counterbalancing cells, so it says only what the design did.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable

from hcss.platform.study.settings import Study
from hcss.questionnaires import consent, demographics, pages, post_trial, ranking, sart, tlx

PLACEHOLDER = re.compile(r"\{\{\s*([a-z_]+)\s*\}\}")
NUMBER_WORDS = ("no", "one", "two", "three", "four", "five", "six")
ORDINALS = ("first", "second", "third", "fourth", "fifth", "sixth")
# How the debrief names each model to a participant (it describes them in this order).
MODEL_NAMES = {
    "M1": "the type that follows the original honeybee model",
    "M2": "the type with added delays",
    "M3": "the type with no deliberation of its own",
}
# The untimed parts are estimated from what they hold: each answer takes about
# ANSWER_S seconds and each text is read at READING_WPM words a minute.
ANSWER_S = 10
READING_WPM = 200


def plural(count: float, noun: str) -> str:
    """'1 minute', '2 minutes', '1.5 minutes'."""
    return f"{count:g} {noun}{'' if count == 1 else 's'}"


def duration(seconds: float) -> str:
    """A length of time as a noun phrase: '20 minutes', '1 minute', '90 seconds'."""
    if seconds % 60 == 0:
        return plural(seconds / 60, "minute")
    return plural(seconds, "second")


def length(seconds: float) -> str:
    """A length of time as an adjective: '20-minute', '1-minute', '90-second'."""
    if seconds % 60 == 0:
        return f"{seconds / 60:g}-minute"
    return f"{seconds:g}-second"


def number_word(count: int) -> str:
    return NUMBER_WORDS[count] if count < len(NUMBER_WORDS) else str(count)


def mrt_minutes(study: Study) -> int:
    """The spatial test's length: its timed parts and breaks, instructions and practice."""
    mrt = study.mrt
    timed = len(mrt.part_items) * mrt.part_time_limit_s + (len(mrt.part_items) - 1) * mrt.break_s
    return math.ceil(timed / 60 + 1 + 0.5 * mrt.practice_items)


def timed_minutes(study: Study) -> float:
    """The parts whose length the study file fixes: the spatial test, trainings and trials."""
    stages = set(study.sequence.before) | set(study.sequence.after) | set(study.sequence.per_model)
    minutes = mrt_minutes(study) if "mental_rotation" in stages else 0.0
    per_model = (
        ("training" in stages) * study.timing.training_s
        + ("trial" in stages) * study.timing.trial_s
    ) / 60
    return minutes + len(study.models) * per_model


def answers(stage: str, study: Study) -> int:
    """How many answers a stage asks for (ratings, choices, TLX comparisons, ranks)."""
    counts = {
        "demographics": len(demographics.DEMOGRAPHICS.items),
        "post_trial": len(post_trial.POST_TRIAL.items),
        "nasa_tlx": len(tlx.RATINGS.items) + tlx.WEIGHT_TOTAL,
        "sart": len(sart.SART.items),
        "ranking": len(ranking.DIMENSIONS) * len(study.models),
    }
    return counts.get(stage, 0)


def words(stage: str, study: Study) -> int:
    """How many words a stage gives to read (consent, introduction, debrief)."""
    if stage == "consent":
        texts = [consent.consent_text(study.consent_version).markdown]
    elif stage == "introduction":
        texts = [page.markdown for page in pages.introduction_pages()]
    elif stage == "debrief":
        texts = [pages.debrief_text().markdown]
    else:
        return 0
    return sum(len(text.split()) for text in texts)


def session_minutes(study: Study) -> float:
    """The whole session as the study file lays it out: its timed parts exactly, and
    the untimed ones from the answers they ask for and the words they give to read.

    Only the stages the file lists count, so a study without questionnaires,
    or a demo with short trials, is never promised a longer session than it has.
    """
    stages = [*study.sequence.before, *study.sequence.after] + [
        s for _ in study.models for s in study.sequence.per_model
    ]
    answering = sum(answers(stage, study) for stage in stages) * ANSWER_S / 60
    reading = sum(words(stage, study) for stage in dict.fromkeys(stages)) / READING_WPM
    return timed_minutes(study) + answering + reading


def about(minutes: float) -> str:
    """A rounded estimate: 'about 40 minutes', 'about two hours', 'about 1.5 hours'."""
    if minutes < 60:
        return f"about {plural(max(5, 5 * round(minutes / 5)), 'minute')}"
    hours = round(minutes / 30) / 2
    if hours == int(hours):
        return f"about {number_word(int(hours))} hour{'' if hours == 1 else 's'}"
    return f"about {plural(hours, 'hour')}"


def facts(study: Study) -> dict[str, str]:
    """Every placeholder's text for this study."""
    count = len(study.models)
    return {
        "training_length": length(study.timing.training_s),
        "trial_length": length(study.timing.trial_s),
        "training_duration": duration(study.timing.training_s),
        "trial_duration": duration(study.timing.trial_s),
        "mrt_duration": f"about {plural(mrt_minutes(study), 'minute')}",
        "session_duration": about(session_minutes(study)),
        "model_count": number_word(count),
        "model_count_times": f"{number_word(count).capitalize()} time{'' if count == 1 else 's'}",
        "order_sentence": order_sentence(study),
    }


def fill(markdown: str, study: Study) -> str:
    """The text with the study's values in place of its placeholders."""
    values = facts(study)

    def value(match: re.Match[str]) -> str:
        name = match.group(1)
        if name not in values:
            raise KeyError(f"the text asks for {{{{ {name} }}}}, which no study provides")
        return values[name]

    return PLACEHOLDER.sub(value, markdown)


def _join(items: Iterable[str]) -> str:
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def order_sentence(study: Study) -> str:
    """What the counterbalancing did, in the participant's words, from the study's cells."""
    count = len(study.models)
    positions = {m: {cell.model_order.index(m) for cell in study.cells} for m in study.models}
    sections = {m: {cell.first_sections[m] for cell in study.cells} for m in study.models}
    fixed = [m for m in study.models if len(positions[m]) == 1]
    varied = [m for m in study.models if len(positions[m]) > 1]
    clauses = []
    for model in fixed:
        position = next(iter(positions[model]))
        place = "last" if position == count - 1 and count > 1 else ORDINALS[position]
        clauses.append(f"{MODEL_NAMES.get(model, model)} always came {place}")
    if varied and fixed:
        clauses.append(
            f"the order of the other {number_word(len(varied))} varied between participants"
        )
    elif varied:
        clauses.append("the order of the types varied between participants")
    sentence = "The order in which you met the types was set by the study design: "
    sentence += _join(clauses) + "."
    section_varied = [m for m in study.models if len(sections[m]) > 1]
    section_fixed = [m for m in study.models if len(sections[m]) == 1]
    if section_varied:
        sentence += " Whether a trial began with its easy or its difficult situation also varied"
        if section_fixed:
            sentence += ", except that " + _join(
                f"the trial with {MODEL_NAMES.get(m, m)} always began with the "
                f"{next(iter(sections[m]))} one"
                for m in section_fixed
            )
        sentence += "."
    elif section_fixed:
        sentence += " " + " ".join(
            f"The trial with {MODEL_NAMES.get(m, m)} began with the {next(iter(sections[m]))} situation."
            for m in section_fixed
        )
    return sentence
