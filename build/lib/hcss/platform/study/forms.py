"""Flask-WTF forms built from the instrument definitions of hcss.questionnaires.

The questionnaire module describes each item once (prompt, choices or scale)
and owns the rules; the forms here only render those items and run the same
checks through WTForms validators, so a message shown to a participant is the
instrument's own. Rules spanning several items (TLX pairs, ranking
permutations) come from the instrument's `validate` and are attached to the
fields they concern by `attach_errors`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from flask_wtf import FlaskForm
from wtforms import HiddenField, RadioField, SelectMultipleField
from wtforms.validators import InputRequired, ValidationError
from wtforms.widgets import CheckboxInput, ListWidget

from hcss.questionnaires.definitions import (
    ChoiceItem,
    Item,
    RatingItem,
    ValidationErrors,
    check_choice,
    check_rating,
)

ANSWER_NEEDED = "This question needs an answer."

try:  # WTForms 3.3 deprecates (value, label) tuples; older versions have only those
    from wtforms.fields.choices import SelectChoice as _Choice
except ImportError:  # pragma: no cover
    _Choice = None


def _choices(pairs: Iterable[tuple[str, str]]) -> list[Any]:
    return [pair if _Choice is None else _Choice(*pair) for pair in pairs]


class ItemRule:
    """A WTForms validator running the definition's own check for one item."""

    def __init__(self, item: Item) -> None:
        self.item = item

    def __call__(self, form: FlaskForm, field: Any) -> None:
        if isinstance(self.item, RatingItem):
            messages = check_rating(self.item, field.data)
        else:
            messages = check_choice(self.item, field.data)
        if messages:
            raise ValidationError(messages[0])


def item_field(item: Item) -> RadioField:
    """Radio buttons for a choice or for every point of a rating scale."""
    if isinstance(item, ChoiceItem):
        pairs = [(choice.value, choice.label) for choice in item.choices]
    else:
        labels = item.point_labels or tuple(str(point) for point in item.points())
        pairs = [(str(point), label) for point, label in zip(item.points(), labels, strict=True)]
    return RadioField(
        item.prompt,
        choices=_choices(pairs),
        validators=[InputRequired(ANSWER_NEEDED), ItemRule(item)],
        validate_choice=False,  # ItemRule gives the instrument's own message
        description=item.help_text,
    )


def form_of(fields: Mapping[str, Any], formdata: Any = None, name: str = "StageForm") -> FlaskForm:
    """An instance of a form class made of these fields (classes are cheap, made per request)."""
    form_class = type(name, (FlaskForm,), dict(fields))
    return form_class(formdata=formdata)


def items_form(items: Iterable[Item], formdata: Any = None) -> FlaskForm:
    return form_of({item.key: item_field(item) for item in items}, formdata, "ItemsForm")


def pair_field(label: str, sides: Sequence[tuple[str, str]]) -> RadioField:
    """One NASA-TLX comparison: the two subscales, in the order presented."""
    return RadioField(
        label,
        choices=_choices(sides),
        validators=[InputRequired("Please choose one of the two.")],
        validate_choice=False,  # tlx.validate names the two allowed sides
    )


def rank_field(label: str, count: int) -> RadioField:
    return RadioField(
        label,
        choices=_choices((str(rank), str(rank)) for rank in range(1, count + 1)),
        validators=[InputRequired(f"Give the {label} a rank from 1 to {count}.")],
        validate_choice=False,
    )


class SelectionRule:
    """The MRT's own check of a selection of alternatives."""

    def __call__(self, form: FlaskForm, field: Any) -> None:
        from hcss.questionnaires.mrt.scoring import selection_errors

        messages = selection_errors([str(value) for value in field.data or []])
        if messages:
            raise ValidationError(messages[0])


def mrt_form(item_key: str, action: str, formdata: Any = None) -> FlaskForm:
    """Tick any of the alternatives A-D; `item` and `action` say what is being answered."""
    fields = {
        "item": HiddenField(default=item_key),
        "action": HiddenField(default=action),
        "chosen": SelectMultipleField(
            "Figures that are the target turned",
            choices=_choices((str(i), chr(ord("A") + i)) for i in range(4)),
            widget=ListWidget(prefix_label=False),
            option_widget=CheckboxInput(),
            validators=[SelectionRule()],
            validate_choice=False,
        ),
    }
    return form_of(fields, formdata, "MrtForm")


def attach_errors(form: FlaskForm, errors: ValidationErrors) -> None:
    """Put an instrument's messages on the fields they name, the rest on the form."""
    for key, messages in errors.items():
        field = form._fields.get(key)
        target = field.errors if field is not None else form.form_errors
        if isinstance(target, tuple):  # WTForms keeps errors as a tuple before validation
            target = list(target)
            if field is not None:
                field.errors = target
        for message in messages:
            if message not in target:
                target.append(message)


def answers_of(form: FlaskForm, keys: Iterable[str]) -> dict[str, str]:
    """The raw answers of these fields, as text, for validation and storage."""
    return {key: "" if form[key].data is None else str(form[key].data) for key in keys}
