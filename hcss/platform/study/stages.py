"""The study's questionnaire and text stages, and the registry of every stage by name.

Each class is one page type of the study (oTree's page classes): it names
its template and form, and its `submit` validates with the instrument's own
rules before writing answers and scores. The MRT and the live trials have
their own modules.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from flask_wtf import FlaskForm
from wtforms import HiddenField, RadioField

from hcss.platform.models import StudyEnrolment
from hcss.platform.study.forms import (
    answers_of,
    attach_errors,
    form_of,
    item_field,
    items_form,
    pair_field,
    rank_field,
)
from hcss.platform.study.instruction_check import InstructionCheck
from hcss.platform.study.markdown import render_markdown
from hcss.platform.study.mrt_stage import MentalRotation
from hcss.platform.study.screen_check import ScreenCheck
from hcss.platform.study.settings import Study
from hcss.platform.study.stage_protocol import (
    Refused,
    Shown,
    Slot,
    Stage,
    StageContext,
    Submission,
    SubmissionMustFail,
    answered,
)
from hcss.platform.study.texts import fill
from hcss.platform.study.trial_stage import TrainingStage, TrialStage
from hcss.questionnaires import consent, demographics, pages, post_trial, ranking, sart, tlx
from hcss.questionnaires.definitions import Questionnaire, ValidationErrors, ordinal_labels

DECLINE_QUESTION = (
    "You chose not to take part. If that is right, press Confirm: the study ends here and "
    "nothing is kept except that you declined. To take part after all, choose I agree."
)


class Consent(Stage):
    name = "consent"
    template = "study/consent.html"
    title = "Consent"

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        fields = {
            "decision": item_field(consent.DECISION),
            "version": HiddenField(default=here.study.consent_version),
            # "yes" once the participant has been asked to confirm a decline.
            "confirm_decline": HiddenField(default=""),
        }
        return form_of(fields, formdata, "ConsentForm")

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        text = consent.consent_text(here.study.consent_version)
        return {"text_html": render_markdown(fill(text.markdown, here.study))}

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        answers = answers_of(form, ("decision", "version"))
        errors = consent.validate(answers)
        if not errors and answers["version"] != here.study.consent_version:
            errors["version"] = ["The consent text has changed; please read it again."]
        if errors:
            attach_errors(form, errors)
            return False
        if answers["decision"] == "decline" and form["confirm_decline"].data != "yes":
            # Declining ends the study for good: ask once before recording it.
            form["confirm_decline"].data = "yes"
            attach_errors(form, {"": [DECLINE_QUESTION]})
            return False
        here.flow.record_consent(answers["version"], answers["decision"])
        return True

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        return (SubmissionMustFail({"decision": "maybe"}), Submission({"decision": "agree"}))


class QuestionnaireStage(Stage):
    """One page of rated or chosen items, validated and scored by its instrument module."""

    template = "study/questionnaire.html"
    questionnaire: Questionnaire
    validate: Callable[[Mapping[str, object]], ValidationErrors]
    score: Callable[[Mapping[str, object]], Any] | None = None

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        return items_form(self.questionnaire.items, formdata)

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        return {
            "questionnaire": self.questionnaire,
            "items": [(form[item.key], item) for item in self.questionnaire.items],
        }

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        answers = answers_of(form, self.questionnaire.item_keys())
        errors = type(self).validate(answers)
        if errors:
            attach_errors(form, errors)
            return False
        here.record_answers(self.questionnaire.instrument, answers, here.slot.model)
        score = type(self).score  # a staticmethod: read from the class, not bound
        if score is not None:
            rows = score(answers).rows()
            here.flow.record_scores(tuple(row.for_model(here.slot.model) for row in rows))
        return True

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        return (
            SubmissionMustFail({}),  # every item unanswered
            Submission(answered(self.questionnaire.items, shown.rng)),
        )


class Demographics(QuestionnaireStage):
    name = "demographics"
    title = "About you"
    questionnaire = demographics.DEMOGRAPHICS
    validate = staticmethod(demographics.validate)


class PostTrial(QuestionnaireStage):
    name = "post_trial"
    per_model = True
    title = "About the collective type"
    questionnaire = post_trial.POST_TRIAL
    validate = staticmethod(post_trial.validate)
    score = staticmethod(post_trial.score)


class Sart(QuestionnaireStage):
    name = "sart"
    per_model = True
    title = "Situation awareness"
    questionnaire = sart.SART
    validate = staticmethod(sart.validate)
    score = staticmethod(sart.score)


class NasaTlx(Stage):
    """Six ratings, then the 15 comparisons in a random order kept from first display."""

    name = "nasa_tlx"
    per_model = True
    title = "Workload"
    template = "study/nasa_tlx.html"

    def steps(self, here: StageContext) -> tuple[str, ...]:
        return ("ratings", "comparisons")

    def on_enter(self, here: StageContext) -> dict[str, Any] | None:
        if here.step != "comparisons":
            return None
        order = tlx.comparison_order(np.random.default_rng())
        return {"presentation": tlx.presentation_record(order)}

    def _order(self, here: StageContext) -> tuple[tlx.PresentedPair, ...]:
        entered = here.event("entered", "comparisons")
        if entered is None or not entered.detail:
            raise Refused("The comparisons have not been shown yet; please reload the page.")
        return tlx.order_from_record(entered.detail["presentation"])

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        if here.step == "ratings":
            return items_form(tlx.SUBSCALES, formdata)
        fields = {
            presented.pair.key: pair_field(
                f"Comparison {presented.position}",
                [(side, tlx.SUBSCALE_TITLES[side]) for side in (presented.left, presented.right)],
            )
            for presented in self._order(here)
        }
        return form_of(fields, formdata, "TlxPairsForm")

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        if here.step == "ratings":
            return {
                "questionnaire": tlx.RATINGS,
                "items": [(form[item.key], item) for item in tlx.SUBSCALES],
            }
        pairs = self._order(here)
        return {
            "instructions": tlx.COMPARISON_INSTRUCTIONS,
            "pairs": [form[presented.pair.key] for presented in pairs],
        }

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        if here.step == "ratings":
            answers = answers_of(form, tlx.SUBSCALE_KEYS)
            errors = {k: v for k, v in tlx.validate(answers).items() if k in tlx.SUBSCALE_KEYS}
            if errors:
                attach_errors(form, errors)
                return False
            here.record_answers(tlx.INSTRUMENT, answers, here.slot.model)
            return True
        choices = answers_of(form, tlx.PAIR_KEYS)
        ratings = {
            key: value
            for key, value in here.answers(tlx.INSTRUMENT).items()
            if key in tlx.SUBSCALE_KEYS
        }
        errors = tlx.validate(ratings | choices)
        if errors:
            attach_errors(form, errors)
            return False
        shown = here.event("entered", "comparisons")
        assert shown is not None and shown.detail is not None, "submitted before it was shown"
        presentation = shown.detail["presentation"]
        here.record_answers(tlx.INSTRUMENT, choices | presentation, here.slot.model)
        rows = tlx.score(ratings | choices).rows()
        here.flow.record_scores(tuple(row.for_model(here.slot.model) for row in rows))
        return True

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        if shown.step == "ratings":
            return (SubmissionMustFail({}), Submission(answered(tlx.SUBSCALES, shown.rng)))
        # The comparisons' sides are in the order drawn for this participant: read the page.
        sides = {key: str(shown.rng.choice(values)) for key, values in shown.radios.items()}
        return (SubmissionMustFail({}), Submission(sides))


class Ranking(Stage):
    """The three models ranked on each dimension, named only by the order they were met."""

    name = "ranking"
    title = "Comparing the collective types"
    template = "study/ranking.html"

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        fields: dict[str, RadioField] = {}
        for dimension in ranking.DIMENSIONS:
            for label in ranking.ORDER_LABELS:
                fields[ranking.item_key(dimension.key, label)] = rank_field(
                    ranking.display_name(label), ranking.MODEL_COUNT
                )
        return form_of(fields, formdata, "RankingForm")

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        dimensions = [
            (
                dimension,
                [form[ranking.item_key(dimension.key, label)] for label in ranking.ORDER_LABELS],
                getattr(form, "dimension_errors", {}).get(dimension.key, []),
            )
            for dimension in ranking.DIMENSIONS
        ]
        return {"instructions": ranking.INSTRUCTIONS, "dimensions": dimensions}

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        answers = answers_of(form, ranking.ITEM_KEYS)
        errors = ranking.validate(answers)
        if errors:
            form.dimension_errors = {
                d.key: errors.pop(d.key) for d in ranking.DIMENSIONS if d.key in errors
            }
            attach_errors(form, errors)
            return False
        order = here.flow.enrolment.models()
        for label in ranking.ORDER_LABELS:
            model = ranking.model_for_label(label, order)
            labelled = {k: v for k, v in answers.items() if k.endswith(f"_{label}")}
            here.record_answers(ranking.INSTRUMENT, labelled, model)
        here.flow.record_scores(ranking.score(answers, order).rows())
        return True

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        ties, ranks = {}, {}
        for dimension in ranking.DIMENSIONS:
            drawn = shown.rng.permutation(ranking.MODEL_COUNT) + 1
            for label, rank in zip(ranking.ORDER_LABELS, drawn, strict=True):
                key = ranking.item_key(dimension.key, label)
                ties[key], ranks[key] = "1", str(rank)
        return (SubmissionMustFail(ties), Submission(ranks))


class Introduction(Stage):
    """The interface walk-through, one page per step, untimed."""

    name = "introduction"
    title = "Introduction"
    template = "study/text_page.html"

    def steps(self, here: StageContext) -> tuple[str, ...]:
        return tuple(f"page_{page.number}" for page in pages.introduction_pages())

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        all_pages = pages.introduction_pages()
        page = all_pages[int(here.step.removeprefix("page_")) - 1]
        return {
            "text_html": render_markdown(fill(page.markdown, here.study)),
            "page_number": page.number,
            "page_count": len(all_pages),
        }


class Debrief(Stage):
    """The last page: reaching it completes the study, so it needs no submission."""

    name = "debrief"
    title = "Thank you"
    template = "study/debrief.html"

    def poll(self, here: StageContext, entered: Any) -> tuple[str, Any] | None:
        return ("submitted", entered.at)


STAGES: dict[str, Stage] = {}
for _stage in (
    Consent,
    Demographics,
    MentalRotation,
    Introduction,
    InstructionCheck,
    ScreenCheck,
    TrainingStage,
    TrialStage,
    PostTrial,
    NasaTlx,
    Sart,
    Ranking,
    Debrief,
):
    STAGES[_stage.name] = _stage()


def sequence(study: Study, enrolment: StudyEnrolment) -> tuple[Slot, ...]:
    """The participant's stages: the study's list with per-model stages in their order."""
    names: list[tuple[str, str, str]] = [(name, "", "") for name in study.sequence.before]
    models = enrolment.models()
    for model, label in zip(models, ordinal_labels(len(models)), strict=True):
        names += [(name, model, label) for name in study.sequence.per_model]
    names += [(name, "", "") for name in study.sequence.after]
    return tuple(
        Slot(index, STAGES[name], model, label) for index, (name, model, label) in enumerate(names)
    )
