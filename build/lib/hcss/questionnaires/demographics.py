"""Demographics: who took part, in bands coarse enough not to identify anyone.

Age is asked as a band rather than a number and nothing is free text, so the
answers can be exported with the participant code alone. Colour-vision
deficiency is asked because the interface codes state by colour and opacity.
"""

from __future__ import annotations

from collections.abc import Mapping

from hcss.questionnaires.definitions import (
    Choice,
    ChoiceItem,
    Questionnaire,
    RatingItem,
    ValidationErrors,
)
from hcss.questionnaires.definitions import validate as validate_items

INSTRUMENT = "demographics"

_EXPERIENCE_LABELS = ("None", "A little", "Some", "A lot", "Extensive")


def _experience(key: str, prompt: str) -> RatingItem:
    return RatingItem(
        key=key,
        prompt=prompt,
        minimum=1,
        maximum=5,
        low_anchor=_EXPERIENCE_LABELS[0],
        high_anchor=_EXPERIENCE_LABELS[-1],
        point_labels=_EXPERIENCE_LABELS,
    )


DEMOGRAPHICS = Questionnaire(
    instrument=INSTRUMENT,
    title="About you",
    instructions="Please answer a few questions about yourself. The questions on your age, "
    "gender, education and colour vision each have a choice that lets you not say.",
    items=(
        ChoiceItem(
            key="age_band",
            prompt="How old are you?",
            choices=(
                Choice("18-30", "18 to 30"),
                Choice("31-50", "31 to 50"),
                Choice("51+", "51 or older"),
                Choice("not_said", "Prefer not to say"),
            ),
        ),
        ChoiceItem(
            key="gender",
            prompt="What is your gender?",
            choices=(
                Choice("woman", "Woman"),
                Choice("man", "Man"),
                Choice("non_binary", "Non-binary"),
                Choice("another", "Another gender"),
                Choice("not_said", "Prefer not to say"),
            ),
        ),
        ChoiceItem(
            key="education",
            prompt="What is the highest level of education you have completed or are studying for?",
            choices=(
                Choice("secondary", "Secondary school"),
                Choice("vocational", "Vocational training or college diploma"),
                Choice("bachelor", "Bachelor's degree"),
                Choice("master", "Master's degree"),
                Choice("doctorate", "Doctorate"),
                Choice("other", "Other"),
                Choice("not_said", "Prefer not to say"),
            ),
        ),
        ChoiceItem(
            key="colour_vision",
            prompt="Do you have a colour-vision deficiency (colour blindness)?",
            choices=(
                Choice("yes", "Yes"),
                Choice("no", "No"),
                Choice("unsure", "Unsure"),
                Choice("not_said", "Prefer not to say"),
            ),
        ),
        _experience("video_games", "How much experience do you have with playing video games?"),
        _experience("robots", "How much experience do you have with robots?"),
    ),
)

ITEM_KEYS = DEMOGRAPHICS.item_keys()


def validate(answers: Mapping[str, object]) -> ValidationErrors:
    """Per-field messages for a form; empty when every answer is one of the offered choices."""
    return validate_items(DEMOGRAPHICS, answers)
