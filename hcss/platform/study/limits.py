"""The study file's `[timeouts]`: when an abandoned participant stops holding a place.

An online participant who closes the tab halfway never says so. Without a
time-out they stay "in progress" forever, keep their counterbalancing cell and
count against the recruitment target. These settings say after how long
without a sign of life (`inactivity_s`), or after how long in all
(`overall_s`), the server marks them timed out (hcss.platform.study.timeouts),
and whether their cell is then free for a new arrival (`free_cell`).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import ConfigDict, Field, StrictBool
from pydantic.dataclasses import dataclass as pydantic_dataclass

Seconds = Annotated[float, Field(ge=0, strict=False)]


@pydantic_dataclass(frozen=True, config=ConfigDict(extra="forbid"))
class Timeouts:
    """0 turns a limit off; both are off unless the study file sets them."""

    inactivity_s: Seconds = 0.0
    overall_s: Seconds = 0.0
    free_cell: StrictBool = True

    @property
    def active(self) -> bool:
        return bool(self.inactivity_s or self.overall_s)
