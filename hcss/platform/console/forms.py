"""The console's forms: every POST goes through Flask-WTF, so every POST has CSRF."""

from __future__ import annotations

from flask_wtf import FlaskForm
from wtforms import BooleanField, IntegerField, PasswordField, StringField
from wtforms.validators import DataRequired, InputRequired, Length, NumberRange, Optional

MAX_NEW_PARTICIPANTS = 50


class LoginForm(FlaskForm):
    username = StringField("Username", validators=[DataRequired(), Length(max=64)])
    password = PasswordField("Password", validators=[DataRequired(), Length(max=256)])


class CreateParticipantsForm(FlaskForm):
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


class ActionForm(FlaskForm):
    """A button: nothing to fill in, but the POST still carries its CSRF token."""


class WithdrawForm(FlaskForm):
    confirm_code = StringField(
        "Type the participant code to confirm", validators=[DataRequired(), Length(max=32)]
    )
