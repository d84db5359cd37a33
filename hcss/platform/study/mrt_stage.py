"""The Mental Rotations Test stage: instructions, practice with feedback, timed parts, breaks.

Items are shown one at a time and each answer is stored as it is given, so a
participant who closes the tab mid-part comes back to the next unanswered
item with the part's deadline unchanged; once the deadline has passed, the
part is recorded as timed out and its unanswered items score nothing.
"""

from __future__ import annotations

from typing import Any

from flask_wtf import FlaskForm
from markupsafe import Markup

from hcss.platform.study.forms import mrt_form
from hcss.platform.study.markdown import render_markdown
from hcss.platform.study.settings import MrtTable
from hcss.platform.study.stage_protocol import Refused, Stage, StageContext
from hcss.platform.study.texts import duration, number_word
from hcss.questionnaires import mrt
from hcss.questionnaires.definitions import ScoreRow
from hcss.questionnaires.mrt.items import MrtItem
from hcss.questionnaires.mrt.protocol import INSTRUCTIONS, INSTRUMENT


def _parts(settings: MrtTable) -> tuple[tuple[MrtItem, ...], ...]:
    """The study's parts: consecutive runs of the item bank, as long as the study says."""
    bank, parts, start = mrt.item_bank(), [], 0
    for count in settings.part_items:
        parts.append(bank[start : start + count])
        start += count
    return tuple(parts)


def _practice_sentence(count: int) -> str:
    """The practice, counted: one practice row is not "a few"."""
    if count == 0:
        return ""
    if count == 1:
        return " First, a practice row shows you whether your answers were right."
    return f" First, {number_word(count)} practice rows show you whether your answers were right."


def _instructions(settings: MrtTable) -> Markup:
    """The protocol's instructions, with the paragraph on parts and timing made to fit the study."""
    parts = settings.part_items
    counts = " and ".join(str(n) for n in parts)
    timing = (
        f"The test has {len(parts)} part{'s' if len(parts) > 1 else ''} of {counts} rows. "
        f"You have {duration(settings.part_time_limit_s)} for each part"
        + (", with a short break between them." if len(parts) > 1 else ".")
        + " Work quickly but carefully."
        + _practice_sentence(settings.practice_items)
    )
    paragraphs = [p for p in INSTRUCTIONS.split("\n\n") if not p.startswith("The test has")]
    return render_markdown("\n\n".join([*paragraphs, timing]))


class MentalRotation(Stage):
    name = "mental_rotation"
    title = "Mental Rotations Test"
    template = "study/mrt.html"

    def steps(self, here: StageContext) -> tuple[str, ...]:
        """Instructions, practice, "Part 1 begins", then each part (after a break from the
        second on). Every part ends on a page that says so: "time is up" when its time
        ran out, "part done" when every item was answered in time, so finishing early
        never drops a participant into the break or the next stage unannounced."""
        steps = ["instructions"]
        steps += [f"practice_{n}" for n in range(1, here.study.mrt.practice_items + 1)]
        for number in range(1, len(here.study.mrt.part_items) + 1):
            steps.append("begin_1" if number == 1 else f"break_{number - 1}")
            steps.append(f"part_{number}")
            if here.event("timed_out", f"part_{number}") is not None:
                steps.append(f"time_up_{number}")
            elif here.event("submitted", f"part_{number}") is not None:
                steps.append(f"done_{number}")
        return tuple(steps)

    def timeout_s(self, here: StageContext) -> float | None:
        if here.step.startswith("part_"):
            return here.study.mrt.part_time_limit_s
        if here.step.startswith("break_"):
            return here.study.mrt.break_s
        return None

    # --- which item ------------------------------------------------------------------

    def _practice_item(self, step: str) -> MrtItem:
        return mrt.practice_items()[int(step.removeprefix("practice_")) - 1]

    def _part_items(self, here: StageContext) -> tuple[MrtItem, ...]:
        return _parts(here.study.mrt)[int(here.step.removeprefix("part_")) - 1]

    def _answered_in(self, here: StageContext, number: int) -> int:
        answered = here.answers(INSTRUMENT)
        return sum(item.key in answered for item in _parts(here.study.mrt)[number - 1])

    def _next_item(self, here: StageContext) -> tuple[int, MrtItem] | None:
        answered = here.answers(INSTRUMENT)
        for number, item in enumerate(self._part_items(here), start=1):
            if item.key not in answered:
                return number, item
        return None

    # --- pages -----------------------------------------------------------------------

    def form(self, here: StageContext, formdata: Any = None) -> FlaskForm:
        if here.step.startswith("practice_"):
            item = self._practice_item(here.step)
            answered = item.key in here.answers(INSTRUMENT)
            return mrt_form(item.key, "continue" if answered else "answer", formdata)
        if here.step.startswith("part_"):
            current = self._next_item(here)
            return mrt_form(current[1].key if current else "", "answer", formdata)
        return FlaskForm(formdata=formdata)

    def context(self, here: StageContext, form: FlaskForm) -> dict[str, Any]:
        if here.step == "instructions":
            return {"kind": "instructions", "text_html": _instructions(here.study.mrt)}
        settings = here.study.mrt
        if here.step == "begin_1" or here.step.startswith("break_"):
            number = 1 if here.step == "begin_1" else int(here.step.removeprefix("break_")) + 1
            return {
                "kind": "begin" if here.step == "begin_1" else "break",
                "next_part": number,
                "part_count": len(settings.part_items),
                "items": settings.part_items[number - 1],
                "limit": duration(settings.part_time_limit_s),
            }
        if here.step.startswith("done_"):
            number = int(here.step.removeprefix("done_"))
            return {
                "kind": "done",
                "part": number,
                "items": settings.part_items[number - 1],
                "part_count": len(settings.part_items),
                "last": number == len(settings.part_items),
                "limit": duration(settings.part_time_limit_s),
            }
        if here.step.startswith("time_up_"):
            number = int(here.step.removeprefix("time_up_"))
            return {
                "kind": "time_up",
                "part": number,
                "answered": self._answered_in(here, number),
                "items": settings.part_items[number - 1],
                "last": number == len(settings.part_items),
            }
        if here.step.startswith("practice_"):
            item = self._practice_item(here.step)
            answer = here.answers(INSTRUMENT).get(item.key)
            feedback = None if answer is None else mrt.practice_feedback(item, answer)
            return {
                "kind": "practice",
                "item": item,
                "svgs": _svgs(item),
                "feedback": feedback,
                "chosen_before": set((answer or "").split(",")) - {""},
                "number": int(here.step.removeprefix("practice_")),
                "count": here.study.mrt.practice_items,
            }
        found: tuple[int, MrtItem | None] = self._next_item(here) or (0, None)
        number, next_item = found
        return {
            "kind": "part",
            "part": int(here.step.removeprefix("part_")),
            "item": next_item,
            "svgs": None if next_item is None else _svgs(next_item),
            "number": number,
            "count": len(self._part_items(here)),
            "feedback": None,  # timed items are answered, never marked
            "chosen_before": set(),
        }

    # --- answers ---------------------------------------------------------------------

    def submit(self, here: StageContext, form: FlaskForm) -> bool:
        if not here.step.startswith(("practice_", "part_")):
            return True
        answered = here.answers(INSTRUMENT)
        item_key, action = form["item"].data, form["action"].data
        selection = mrt.format_selection([int(value) for value in form["chosen"].data or []])
        if here.step.startswith("practice_"):
            item = self._practice_item(here.step)
            if item_key != item.key:
                raise Refused("This is not the practice item you are on; please reload the page.")
            if action == "continue":
                if item.key not in answered:
                    raise Refused("Please answer the practice item first.")
                return True
            if item.key in answered:
                raise Refused("This practice item has already been answered.")
            here.record_answers(INSTRUMENT, {item.key: selection})
            return False  # show the feedback on the same step
        current = self._next_item(here)
        if current is None or item_key != current[1].key:
            raise Refused("This item has already been answered or is not the current one.")
        here.record_answers(INSTRUMENT, {item_key: selection})
        if self._next_item(here) is not None:
            return False
        self._score_if_last(here)
        return True

    def on_timeout(self, here: StageContext) -> None:
        self._score_if_last(here)

    def _score_if_last(self, here: StageContext) -> None:
        """Score the whole test when its last part ends, answered or timed out."""
        if here.step != f"part_{len(here.study.mrt.part_items)}":
            return
        parts = _parts(here.study.mrt)
        items = tuple(item for part in parts for item in part)
        answers = {
            key: value
            for key, value in here.answers(INSTRUMENT).items()
            if key in {item.key for item in items}
        }
        result = mrt.score(answers, items)
        credit = dict(result.item_scores)
        rows = [ScoreRow(INSTRUMENT, "total", float(result.total))]
        rows += [
            ScoreRow(INSTRUMENT, f"part_{n}", float(sum(credit[item.key] for item in part)))
            for n, part in enumerate(parts, start=1)
        ]
        here.flow.record_scores(tuple(rows))


def _svgs(item: MrtItem) -> dict[str, Any]:
    """The generated drawings; trusted markup from hcss.questionnaires' SVG renderer."""
    return {
        "target": Markup(item.target_svg()),
        "alternatives": [Markup(svg) for svg in item.alternative_svgs()],
    }
