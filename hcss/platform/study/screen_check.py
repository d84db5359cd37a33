"""The screen and browser check before the first training.

The Collective Interface needs a window of at least the study file's
`[requirements]` size (1024 x 620 CSS pixels by default) and a browser with
EventSource, fetch and SVG. The study link's first page checked the device
before consent; this check is for a window made smaller since. The page measures the window
as it is now and again whenever it changes: too small, it says so and keeps
Continue disabled; large enough, the message clears itself. The size is
posted with the form and checked again here, so a page with scripts off
cannot skip the check.
"""

from __future__ import annotations

from typing import Any

from flask_wtf import FlaskForm
from wtforms import IntegerField
from wtforms.validators import InputRequired, NumberRange

from hcss.platform.study.forms import attach_errors, form_of
from hcss.platform.study.requirements import MAX_PIXELS
from hcss.platform.study.stage_protocol import (
    Shown,
    Stage,
    StageContext,
    Submission,
    SubmissionMustFail,
)


def _size_field(name: str) -> IntegerField:
    return IntegerField(
        name,
        validators=[
            InputRequired("Your browser did not report its window size; please enable scripts."),
            NumberRange(0, MAX_PIXELS, "This is not a window size."),
        ],
    )


class ScreenCheck(Stage):
    name = "screen_check"
    title = "Screen check"
    template = "study/screen_check.html"

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        fields = {"width": _size_field("Window width"), "height": _size_field("Window height")}
        return form_of(fields, formdata, "ScreenCheckForm")

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        needed = here.study.requirements
        return {"min_width": needed.min_width, "min_height": needed.min_height}

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        width, height = form["width"].data, form["height"].data
        needed = here.study.requirements
        if width < needed.min_width or height < needed.min_height:
            attach_errors(
                form,
                {
                    "": [
                        f"Your window is {width} x {height} pixels; the trials need at least "
                        f"{needed.min_width} x {needed.min_height}. Please enlarge the window."
                    ]
                },
            )
            return False
        return True

    def bot_submissions(self, shown: Shown) -> tuple[Submission | SubmissionMustFail, ...]:
        # A bot's window is comfortably large enough; no window is -1 pixels wide.
        return (
            SubmissionMustFail({"width": "-1", "height": "800"}),
            Submission({"width": "1280", "height": "800"}),
        )
