"""The training's start page says what to try, and when the first targets come."""

from __future__ import annotations

import re

from tests.support.study import new_participant, visitor, walk_to


def test_the_training_start_page_lists_what_to_try(demo_bot_app) -> None:
    guest = visitor(demo_bot_app, new_participant(demo_bot_app))
    walk_to(guest, "training", "ready")
    text = re.sub(r"<[^>]+>", "", guest.html)
    assert "What to try" in text
    assert "The first targets appear within half a minute" in text
    tries = re.findall(r"<li>(.*?)</li>", guest.html.split('id="what-to-try-list"')[1])
    assert len(tries) == 5, tries
    for kind in ("Investigate", "Decide", "Abandon"):
        assert f"<strong>{kind}</strong>" in guest.html
