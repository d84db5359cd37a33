"""The participant's texts follow the study file: durations, counts, plurals and the design.

Every text is rendered for `original` and `demo` and its numbers are checked
against the study file (the expected phrases are worked out by hand below from
the two TOML files), and the consent and debrief pages show the participant's
code, as the texts tell participants to quote it to withdraw.
"""

from __future__ import annotations

import re

import pytest

from hcss.platform.study.studyfile import load_study
from hcss.platform.study.texts import (
    about,
    duration,
    fill,
    length,
    order_sentence,
    session_minutes,
    timed_minutes,
)
from hcss.questionnaires import consent, pages
from tests.support.study import new_participant, visitor

# By hand from the bundled study files (hcss/platform/study/bundled/*.toml) and the texts:
#   answers: demographics 6; per model post-trial 6 + NASA-TLX 6 ratings and 15 comparisons
#            + SART 3 = 30; ranking 3 dimensions x 3 types = 9 -> 105 answers x 10 s = 17.5 min.
#   reading: consent 413 words, introduction 363 + 327 + 336 + 295 + 327, debrief 267
#            = 2328 words at 200 a minute = 11.64 min.
#   original: training 300 s, trial 1200 s, MRT 2 parts x 180 s + one 60 s break,
#             4 practice items -> 7 + 1 (instructions) + 2 (practice) = 10 minutes;
#             timed 10 + 3 x (5 + 20) = 85; session 85 + 17.5 + 11.64 = 114.1 -> about two hours.
#   demo:     training 60 s, trial 120 s, MRT 1 part x 60 s, 1 practice item
#             -> 1 + 1 + 0.5 = 2.5 -> 3 minutes; timed 3 + 3 x (1 + 2) = 12;
#             session 12 + 17.5 + 11.64 = 41.1 -> about 40 minutes.
#   demo without the per-model questionnaires: 12 + (6 + 9) x 10 s + 11.64 = 26.1
#             -> about 25 minutes.
EXPECTED = {
    "original": {
        "consent": [
            "a 5-minute training",
            "a 20-minute trial",
            "(about 10 minutes)",
            "takes about two hours",
            "Three times",
            "Rank the three types",
        ],
        "introduction": [
            "a 5-minute **training**",
            "a 20-minute **trial**",
            "A trial lasts 20 minutes",
            "meet three different",
        ],
    },
    "demo": {
        "consent": [
            "a 1-minute training",
            "a 2-minute trial",
            "(about 3 minutes)",
            "takes about 40 minutes",
            "Three times",
        ],
        "introduction": [
            "a 1-minute **training**",
            "a 2-minute **trial**",
            "A trial lasts 2 minutes",
        ],
    },
}
WRONG_PLURALS = re.compile(r"\b1 (minutes|seconds|hours)\b|\b(2|3|4|5|10|20) (minute|hour)\b")


def test_the_session_estimate_counts_only_the_stages_the_file_lists() -> None:
    """A study without the questionnaires is promised a shorter session, not a fixed budget."""
    demo = load_study("demo")
    assert timed_minutes(demo) == 12
    assert session_minutes(demo) == pytest.approx(12 + 17.5 + 2328 / 200)
    sequence = demo.sequence.model_copy(update={"per_model": ("training", "trial")})
    trials_only = demo.model_copy(update={"sequence": sequence})
    assert session_minutes(trials_only) == pytest.approx(12 + 15 * 10 / 60 + 2328 / 200)
    assert about(session_minutes(trials_only)) == "about 25 minutes"
    consent_text = fill(consent.consent_text(demo.consent_version).markdown, trials_only)
    assert "takes about 25 minutes" in consent_text
    original = load_study("original")
    assert (timed_minutes(original), about(session_minutes(original))) == (85, "about two hours")


def _texts(study_name: str) -> dict[str, str]:
    study = load_study(study_name)
    return {
        "consent": fill(consent.consent_text(study.consent_version).markdown, study),
        "introduction": "\n".join(fill(p.markdown, study) for p in pages.introduction_pages()),
        "debrief": fill(pages.debrief_text().markdown, study),
    }


@pytest.mark.parametrize("study_name", ["original", "demo"])
def test_each_text_states_the_study_files_numbers(study_name: str) -> None:
    texts = _texts(study_name)
    for name, text in texts.items():
        assert "{{" not in text and "}}" not in text, name
        assert not WRONG_PLURALS.search(text), (name, WRONG_PLURALS.search(text))
        assert "equally often" not in text  # the design never balanced M3's position
    for name, phrases in EXPECTED[study_name].items():
        for phrase in phrases:
            assert phrase in texts[name], (study_name, name, phrase)


def test_the_debrief_says_what_the_counterbalancing_did() -> None:
    # Both studies: M3 always last; M1/M2 order and their first sections varied; M3 easy.
    for name in ("original", "demo"):
        sentence = order_sentence(load_study(name))
        assert sentence == (
            "The order in which you met the types was set by the study design: the type "
            "with no deliberation of its own always came last and the order of the other "
            "two varied between participants. Whether a trial began with its easy or its "
            "difficult situation also varied, except that the trial with the type with no "
            "deliberation of its own always began with the easy one."
        )
        assert sentence in _texts(name)["debrief"]


def test_durations_have_correct_plurals() -> None:
    assert [duration(s) for s in (60, 120, 1200, 90, 1)] == [
        "1 minute",
        "2 minutes",
        "20 minutes",
        "90 seconds",
        "1 second",
    ]
    assert [length(s) for s in (60, 300, 45)] == ["1-minute", "5-minute", "45-second"]


def test_consent_page_and_footer_show_the_participant_code(demo_app) -> None:
    token = new_participant(demo_app)
    guest = visitor(demo_app, token)
    with demo_app.app_context():
        from sqlalchemy import select

        from hcss.platform.models import Participant

        with demo_app.extensions["hcss_db"].session_scope() as session:
            code = session.scalar(select(Participant.code).where(Participant.token == token))
    guest.page()
    assert f'Your participant code is <b class="participant-code">{code}</b>' in guest.html
    assert "a 1-minute training" in guest.html  # the demo's numbers, rendered
    assert f'Your participant code: <b class="participant-code">{code}</b>' in guest.html


def test_demographics_keep_their_promise_and_label_each_scale_end_once(demo_app) -> None:
    from hcss.questionnaires.definitions import ChoiceItem
    from hcss.questionnaires.demographics import DEMOGRAPHICS

    guest = visitor(demo_app, new_participant(demo_app))
    page = guest.page()
    guest.submit({"decision": "agree"}, page)
    guest.page()
    html = guest.html
    assert (
        "age, gender, education and colour vision each have a choice that lets you not say" in html
    )
    for key in ("age_band", "gender", "education", "colour_vision"):
        item = DEMOGRAPHICS.item(key)
        assert isinstance(item, ChoiceItem) and "not_said" in item.values(), key
        assert re.search(rf'<input[^>]*name="{key}"[^>]*value="not_said"', html), key
    # The experience scales label every point ("None" ... "Extensive"); no extra end labels.
    fieldset = html[html.index('id="q-video_games"') :]
    fieldset = fieldset[: fieldset.index("</fieldset>")]
    assert fieldset.count("Extensive") == 1 and fieldset.count(">None<") == 1
    assert 'class="anchor"' not in fieldset


def test_the_mrt_instructions_count_the_practice_rows(demo_app) -> None:
    from tests.support.study import new_participant, visitor

    guest = visitor(demo_app, new_participant(demo_app))
    guest.submit({"decision": "agree"})
    page = guest.page()
    guest.submit({key: page.radios[key][0] for key in page.radios})
    text = guest.page() and guest.html
    assert 'data-stage="mental_rotation"' in text
    assert "First, a practice row shows you" in text  # the demo has one practice item
    assert "a few practice rows" not in text
