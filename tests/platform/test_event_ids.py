"""Stored system messages name targets by the id the participant sees (issue 10 §4).

Regression: a discovery event stored the 0-based array index in SimEvent.target
("discovery 8 | Target 9 discovered."); the export and the replay timeline carried it on.
"""

from __future__ import annotations

import re

from sqlalchemy import select

from hcss.platform.models import SimEvent


def test_every_stored_event_target_is_the_id_in_its_text_and_on_the_map(app, make_trial) -> None:
    trial = make_trial(seed=7, duration_s=120.0)
    seen: set[int] = set()
    for second in range(5, 116, 5):
        trial.run_to(float(second))
        seen |= {t["id"] for t in trial.state()["view"]["targets"]}
    with app.extensions["hcss_db"].session_scope() as session:
        events = session.scalars(select(SimEvent).where(SimEvent.trial_id == trial.trial_id)).all()
        rows = [(e.kind, e.target, e.text) for e in events]
    discoveries = [target for kind, target, _ in rows if kind == "discovery"]
    assert discoveries, "the trial must discover targets within two minutes"
    assert set(discoveries) <= seen
    for kind, target, text in rows:
        if target is None:
            continue
        named = re.search(r"[Tt]arget (\d+)", text)
        assert named is not None and target == int(named.group(1)), (kind, target, text)
