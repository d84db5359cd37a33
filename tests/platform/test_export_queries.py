"""The export reads every participant in a fixed number of queries: at 5,000 participants it
took 166 s (measured by issue 30), several queries per participant."""

from __future__ import annotations

from hcss.platform.console.participants import create_participants
from hcss.platform.export.writer import collect
from tests.support.console import statements


def _links_and_visits(app, count: int) -> None:
    """`count` demo links, every third opened (enrolled, at consent)."""
    with app.test_request_context(), app.extensions["hcss_db"].session_scope() as session:
        made = create_participants(
            session, count=count, pilot=False, cell=None, experimenter=None, now=0.0, study="demo"
        )
        tokens = [p.token for p in made]
    visitor = app.test_client()
    for token in tokens[::3]:
        assert visitor.get(f"/p/{token}", follow_redirects=True).status_code == 200


def test_the_export_costs_the_same_queries_for_6_or_60_participants(app) -> None:
    _links_and_visits(app, 6)
    database = app.extensions["hcss_db"]
    with statements(app) as few, database.session_scope() as session:
        tables = collect(session)
    assert len(tables["participants"]) == 6
    _links_and_visits(app, 54)
    with statements(app) as many, database.session_scope() as session:
        tables = collect(session)
    statuses = sorted({row["status"] for row in tables["participants"]})
    assert len(tables["participants"]) == 60 and statuses == ["in_progress", "not_started"]
    assert many["all"] == few["all"] <= 40, (few, many)
