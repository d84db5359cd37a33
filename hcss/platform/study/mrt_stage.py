"""The Mental Rotations Test stage: instructions, practice with feedback, timed parts, breaks.

Items are shown one at a time and each answer is stored as it is given, so a
participant who closes the tab mid-part comes back to the next unanswered
item with the part's deadline unchanged; once the deadline has passed, the
part is recorded as timed out and its unanswered items score nothing.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from flask_wtf import FlaskForm
from markupsafe import Markup

from hcss.platform.study.forms import mrt_form
from hcss.platform.study.markdown import render_markdown
from hcss.platform.study.stage import Refused, Slot, Stage
from hcss.platform.study.texts import duration, number_word
from hcss.questionnaires import mrt
from hcss.questionnaires.definitions import ScoreRow
from hcss.questionnaires.mrt.items import MrtItem
from hcss.questionnaires.mrt.protocol import INSTRUCTIONS, INSTRUMENT

if TYPE_CHECKING:
    from hcss.platform.study.flow import Flow


def _parts(flow: Flow) -> tuple[tuple[MrtItem, ...], ...]:
    """The study's parts: consecutive runs of the item bank, as long as the study says."""
    bank, parts, start = mrt.item_bank(), [], 0
    for count in flow.study.mrt.part_items:
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


def _instructions(flow: Flow) -> Markup:
    """The protocol's instructions, with the paragraph on parts and timing made to fit the study."""
    settings = flow.study.mrt
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

    def steps(self, flow: Flow, slot: Slot) -> tuple[str, ...]:
        """Instructions, practice, "Part 1 begins", then each part (after a break from the
        second on). Every part ends on a page that says so: "time is up" when its time
        ran out, "part done" when every item was answered in time, so finishing early
        never drops a participant into the break or the next stage unannounced."""
        steps = ["instructions"]
        steps += [f"practice_{n}" for n in range(1, flow.study.mrt.practice_items + 1)]
        for number in range(1, len(flow.study.mrt.part_items) + 1):
            steps.append("begin_1" if number == 1 else f"break_{number - 1}")
            steps.append(f"part_{number}")
            if flow.event(slot.index, f"part_{number}", "timed_out") is not None:
                steps.append(f"time_up_{number}")
            elif flow.event(slot.index, f"part_{number}", "submitted") is not None:
                steps.append(f"done_{number}")
        return tuple(steps)

    def timeout_s(self, flow: Flow, slot: Slot, step: str) -> float | None:
        if step.startswith("part_"):
            return flow.study.mrt.part_time_limit_s
        if step.startswith("break_"):
            return flow.study.mrt.break_s
        return None

    # --- which item ------------------------------------------------------------------

    def _practice_item(self, step: str) -> MrtItem:
        return mrt.practice_items()[int(step.removeprefix("practice_")) - 1]

    def _part_items(self, flow: Flow, step: str) -> tuple[MrtItem, ...]:
        return _parts(flow)[int(step.removeprefix("part_")) - 1]

    def _answered_in(self, flow: Flow, slot: Slot, number: int) -> int:
        answered = flow.answers(slot.index, INSTRUMENT)
        return sum(item.key in answered for item in _parts(flow)[number - 1])

    def _next_item(self, flow: Flow, slot: Slot, step: str) -> tuple[int, MrtItem] | None:
        answered = flow.answers(slot.index, INSTRUMENT)
        for number, item in enumerate(self._part_items(flow, step), start=1):
            if item.key not in answered:
                return number, item
        return None

    # --- pages -----------------------------------------------------------------------

    def form(self, flow: Flow, slot: Slot, step: str, formdata: Any = None) -> FlaskForm:
        if step.startswith("practice_"):
            item = self._practice_item(step)
            answered = item.key in flow.answers(slot.index, INSTRUMENT)
            return mrt_form(item.key, "continue" if answered else "answer", formdata)
        if step.startswith("part_"):
            current = self._next_item(flow, slot, step)
            return mrt_form(current[1].key if current else "", "answer", formdata)
        return FlaskForm(formdata=formdata)

    def context(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> dict[str, Any]:
        if step == "instructions":
            return {"kind": "instructions", "text_html": _instructions(flow)}
        settings = flow.study.mrt
        if step == "begin_1" or step.startswith("break_"):
            number = 1 if step == "begin_1" else int(step.removeprefix("break_")) + 1
            return {
                "kind": "begin" if step == "begin_1" else "break",
                "next_part": number,
                "part_count": len(settings.part_items),
                "items": settings.part_items[number - 1],
                "limit": duration(settings.part_time_limit_s),
            }
        if step.startswith("done_"):
            number = int(step.removeprefix("done_"))
            return {
                "kind": "done",
                "part": number,
                "items": settings.part_items[number - 1],
                "part_count": len(settings.part_items),
                "last": number == len(settings.part_items),
                "limit": duration(settings.part_time_limit_s),
            }
        if step.startswith("time_up_"):
            number = int(step.removeprefix("time_up_"))
            return {
                "kind": "time_up",
                "part": number,
                "answered": self._answered_in(flow, slot, number),
                "items": settings.part_items[number - 1],
                "last": number == len(settings.part_items),
            }
        if step.startswith("practice_"):
            item = self._practice_item(step)
            answer = flow.answers(slot.index, INSTRUMENT).get(item.key)
            feedback = None if answer is None else mrt.practice_feedback(item, answer)
            return {
                "kind": "practice",
                "item": item,
                "svgs": _svgs(item),
                "feedback": feedback,
                "chosen_before": set((answer or "").split(",")) - {""},
                "number": int(step.removeprefix("practice_")),
                "count": flow.study.mrt.practice_items,
            }
        found: tuple[int, MrtItem | None] = self._next_item(flow, slot, step) or (0, None)
        number, next_item = found
        return {
            "kind": "part",
            "part": int(step.removeprefix("part_")),
            "item": next_item,
            "svgs": None if next_item is None else _svgs(next_item),
            "number": number,
            "count": len(self._part_items(flow, step)),
            "feedback": None,  # timed items are answered, never marked
            "chosen_before": set(),
        }

    # --- answers ---------------------------------------------------------------------

    def submit(self, flow: Flow, slot: Slot, step: str, form: FlaskForm) -> bool:
        if not step.startswith(("practice_", "part_")):
            return True
        answered = flow.answers(slot.index, INSTRUMENT)
        item_key, action = form["item"].data, form["action"].data
        selection = mrt.format_selection([int(value) for value in form["chosen"].data or []])
        if step.startswith("practice_"):
            item = self._practice_item(step)
            if item_key != item.key:
                raise Refused("This is not the practice item you are on; please reload the page.")
            if action == "continue":
                if item.key not in answered:
                    raise Refused("Please answer the practice item first.")
                return True
            if item.key in answered:
                raise Refused("This practice item has already been answered.")
            flow.record_answers(slot, INSTRUMENT, {item.key: selection})
            return False  # show the feedback on the same step
        current = self._next_item(flow, slot, step)
        if current is None or item_key != current[1].key:
            raise Refused("This item has already been answered or is not the current one.")
        flow.record_answers(slot, INSTRUMENT, {item_key: selection})
        if self._next_item(flow, slot, step) is not None:
            return False
        self._score_if_last(flow, slot, step)
        return True

    def on_timeout(self, flow: Flow, slot: Slot, step: str) -> None:
        self._score_if_last(flow, slot, step)

    def _score_if_last(self, flow: Flow, slot: Slot, step: str) -> None:
        """Score the whole test when its last part ends, answered or timed out."""
        if step != f"part_{len(flow.study.mrt.part_items)}":
            return
        parts = _parts(flow)
        items = tuple(item for part in parts for item in part)
        answers = {
            key: value
            for key, value in flow.answers(slot.index, INSTRUMENT).items()
            if key in {item.key for item in items}
        }
        result = mrt.score(answers, items)
        credit = dict(result.item_scores)
        rows = [ScoreRow(INSTRUMENT, "total", float(result.total))]
        rows += [
            ScoreRow(INSTRUMENT, f"part_{n}", float(sum(credit[item.key] for item in part)))
            for n, part in enumerate(parts, start=1)
        ]
        flow.record_scores(tuple(rows))


def _svgs(item: MrtItem) -> dict[str, Any]:
    """The generated drawings; trusted markup from hcss.questionnaires' SVG renderer."""
    return {
        "target": Markup(item.target_svg()),
        "alternatives": [Markup(svg) for svg in item.alternative_svgs()],
    }
