"""The screen and browser check before the first training.

The Collective Interface needs a window of at least 1024 x 700 CSS pixels
and a browser with EventSource, fetch and SVG. The page measures the window
as it is now and again whenever it changes: too small, it says so and keeps
Continue disabled; large enough, the message clears itself. The size is
posted with the form and checked again here, so a page with scripts off
cannot skip the check.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from flask_wtf import FlaskForm
from wtforms import IntegerField
from wtforms.validators import InputRequired, NumberRange

from hcss.platform.study.forms import attach_errors, form_of
from hcss.platform.study.stage import Slot, Stage

if TYPE_CHECKING:
    from hcss.platform.study.flow import Flow

MIN_WIDTH, MIN_HEIGHT = 1024, 700
MAX_PIXELS = 100_000  # larger than any screen: anything above is not a measurement


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

    def form(self, flow: Flow, slot: Slot, step: str, formdata: Any = None) -> FlaskForm:
        fields = {"width": _size_field("Window width"), "height": _size_field("Window height")}
        return form_of(fields, formdata, "ScreenCheckForm")

    def context(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> dict[str, Any]:
        return {"min_width": MIN_WIDTH, "min_height": MIN_HEIGHT}

    def submit(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> bool:
        width, height = form["width"].data, form["height"].data
        if width < MIN_WIDTH or height < MIN_HEIGHT:
            attach_errors(
                form,
                {
                    "": [
                        f"Your window is {width} x {height} pixels; the trials need at least "
                        f"{MIN_WIDTH} x {MIN_HEIGHT}. Please enlarge the window."
                    ]
                },
            )
            return False
        return True
