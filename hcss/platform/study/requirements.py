"""What a participant's device must offer, checked on the study link's first page.

A phone user who could never run a trial should learn so before consent,
before any answer is recorded, and with a way back to the recruitment site.
The study file's `[requirements]` table names the window size, whether only
desktop computers may take part, and the browser features the trials need.
The first page measures them in the browser and posts what it measured; the
server decides here, from that measurement, so a page with scripts off or an
edited form cannot skip the check. The screen check before the first
training measures the window again, for a window made smaller since.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal

from pydantic import ConfigDict, Field, StrictBool, StrictInt
from pydantic.dataclasses import dataclass as pydantic_dataclass

#: Browser features the Collective Interface uses, by the names a study file gives them.
Feature = Literal["eventsource", "fetch", "svg", "crypto"]
FEATURES: tuple[Feature, ...] = ("eventsource", "fetch", "svg", "crypto")
#: Larger than any screen: a posted size above it is not a measurement.
MAX_PIXELS = 100_000


#: A window side in CSS pixels.
Pixels = Annotated[StrictInt, Field(ge=0, le=MAX_PIXELS)]


@pydantic_dataclass(frozen=True, config=ConfigDict(extra="forbid"))
class Requirements:
    """The study file's `[requirements]` table; its defaults are what the trials need."""

    min_width: Pixels = 1024
    #: 620 admits a maximised browser on the commonest laptop screens: 1366 x 768 gives a
    #: window of about 1366 x 657 (1366 x 625 with a bookmarks bar), 1280 x 800 about 1280 x 690.
    #: The trial's layout fits 1024 x 620 with every control on screen (test_interface_browser).
    min_height: Pixels = 620
    desktop_only: StrictBool = True
    features: list[Feature] = Field(default_factory=lambda: list(FEATURES))


@dataclass(frozen=True)
class Measurement:
    """What the first page measured: the window in CSS pixels, the device, missing features."""

    width: int
    height: int
    mobile: bool
    missing: tuple[str, ...] = ()


def shortfalls(requirements: Requirements, measured: Measurement) -> list[str]:
    """Each way the device falls short, in words for the participant; empty when it is fine."""
    reasons = []
    if requirements.desktop_only and measured.mobile:
        reasons.append(
            "This study needs a desktop or laptop computer; phones and tablets cannot be used."
        )
    if measured.width < requirements.min_width or measured.height < requirements.min_height:
        reasons.append(
            f"Your browser window is {measured.width} x {measured.height} pixels; the study needs "
            f"at least {requirements.min_width} x {requirements.min_height}."
        )
    lacking = [name for name in requirements.features if name in measured.missing]
    if lacking:
        reasons.append(
            "Your browser lacks features the study needs ("
            + ", ".join(lacking)
            + "); a recent Chrome, Edge, Firefox or Safari has them."
        )
    return reasons
