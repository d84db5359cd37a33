"""The console's forms: every POST goes through Flask-WTF, so every POST has CSRF."""

from __future__ import annotations

import secrets
from typing import Any

from flask_wtf import FlaskForm
from wtforms import (
    BooleanField,
    HiddenField,
    IntegerField,
    PasswordField,
    SelectField,
    StringField,
)
from wtforms.validators import (
    DataRequired,
    InputRequired,
    Length,
    NumberRange,
    Optional,
    Regexp,
)

from hcss.platform.study.enrolment import default_study_name
from hcss.platform.study.files import study_names

MAX_NEW_PARTICIPANTS = 50


def available_studies() -> list[str]:
    """The study files, by name; read on each request so a new file shows at once."""
    return study_names()


class LoginForm(FlaskForm):
    username = StringField("Username", validators=[DataRequired(), Length(max=64)])
    password = PasswordField("Password", validators=[DataRequired(), Length(max=256)])
    code = StringField(
        "One-time code (accounts with a second factor)", validators=[Optional(), Length(max=32)]
    )


class SecondFactorForm(FlaskForm):
    """The enrolment page's confirmation: a code of the secret offered, which it carries back."""

    offer = HiddenField(validators=[DataRequired(), Length(max=512)])
    code = StringField("Code the app shows", validators=[DataRequired(), Length(max=32)])


class CreateParticipantsForm(FlaskForm):
    study = SelectField("Study", validators=[DataRequired()])
    count = IntegerField(
        "How many",
        default=1,
        validators=[InputRequired(), NumberRange(min=1, max=MAX_NEW_PARTICIPANTS)],
    )
    pilot = BooleanField("Pilot participants")
    cell = IntegerField(
        "Counterbalancing cell (override; empty = assigned)",
        validators=[Optional(), NumberRange(min=1, max=64)],
    )
    # A fresh random key in each page's form (hcss.platform.models.console.ConsoleForm):
    # the server carries a key out once. Optional, so a client of its own may post without.
    form_key = HiddenField(
        default=lambda: secrets.token_urlsafe(16),
        validators=[Optional(), Regexp(r"^[A-Za-z0-9_-]{16,64}$", message="not a form key")],
    )

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        names = available_studies()
        self.study.choices = [(name, name) for name in names]
        if self.study.data is None:  # not sent (a blank form, or an older page): the default
            default = default_study_name()
            self.study.data = default if default in names else (names[0] if names else None)


class ActionForm(FlaskForm):
    """A button: nothing to fill in, but the POST still carries its CSRF token."""


class WithdrawForm(FlaskForm):
    confirm_code = StringField(
        "Type the participant code to confirm", validators=[DataRequired(), Length(max=32)]
    )
