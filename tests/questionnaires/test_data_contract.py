"""Instrument names and item keys agree with docs/data-dictionary.md."""

from __future__ import annotations

import re
from pathlib import Path

from hcss.platform.study import instruction_check
from hcss.questionnaires import demographics, post_trial, ranking, sart, tlx
from hcss.questionnaires.mrt import mental_rotations_test

DICTIONARY = Path(__file__).resolve().parents[2] / "docs" / "data-dictionary.md"


def table_row(table: str, column: str) -> str:
    text = DICTIONARY.read_text(encoding="utf-8")
    section = text.split(f"### {table}", 1)[1].split("\n### ", 1)[0]
    return next(line for line in section.splitlines() if line.startswith(f"| {column}"))


def test_instrument_names_are_those_of_the_questionnaire_items_table() -> None:
    allowed = set(re.findall(r"`([a-z_]+)`", table_row("questionnaire_items", "instrument")))
    ours = {
        demographics.INSTRUMENT,
        mental_rotations_test().instrument,
        post_trial.INSTRUMENT,
        tlx.INSTRUMENT,
        sart.INSTRUMENT,
        ranking.INSTRUMENT,
        instruction_check.INSTRUMENT,
    }
    assert ours == allowed


def test_item_keys_follow_the_dictionary_examples() -> None:
    examples = re.findall(r"`([a-z_0-9]+)`", table_row("questionnaire_items", "item"))
    keys = set(tlx.ITEM_KEYS) | set(mental_rotations_test().item_keys())
    assert set(examples) <= keys
    participant_columns = table_row("participants", "age_band, gender, education, colour_vision")
    for key in demographics.ITEM_KEYS:
        assert key in participant_columns


def test_score_scales_include_the_dictionary_examples() -> None:
    examples = set(re.findall(r"`([A-Za-z_]+)`", table_row("scores", "scale")))
    scales = {"overall", "raw_tlx", "SU", "effectiveness", "responsiveness"}
    scales |= {"passed", "tries"}  # the instruction check's (hcss.platform.study.instruction_check)
    scales |= {f"{key}_weighted" for key in tlx.SUBSCALE_KEYS}
    assert examples <= scales
    sart_scales = {row.scale for row in sart.score(dict.fromkeys(sart.ITEM_KEYS, 4)).rows()}
    assert {"overall", "SU", "DAR", "SAR"} == sart_scales
    post_scales = {
        row.scale for row in post_trial.score(dict.fromkeys(post_trial.ITEM_KEYS, 4)).rows()
    }
    assert {"effectiveness", "responsiveness"} <= post_scales
