"""The links page and links.csv: batches with their created and opened counts, each link's
batch, creation, first visit and status, "Copy all" of the usable links only, and a cost in
queries that does not grow with the number of participants."""

from __future__ import annotations

import csv
import io
import re

from tests.support.console import statements

LINK = re.compile(r'data-copy="(http://localhost/p/[A-Za-z0-9_-]+)" data-usable="([01])"')


def _batch(console, count: int) -> list[str]:
    created = console.post("/console/participants", {"study": "demo", "count": str(count)})
    assert created.status_code == 303
    html = console.get(created.headers["Location"]).get_data(as_text=True)
    return [link for link, _ in LINK.findall(html)]


def test_batches_and_links_show_created_opened_and_status(app, console) -> None:
    first, second = _batch(console, 3), _batch(console, 2)
    visitor = app.test_client()
    for link in (first[0], second[1]):
        assert visitor.get(link, follow_redirects=True).status_code == 200
    (aborted_code,) = [
        code for code, row in console.progress().items() if row["stage"] == "not started"
    ][:1]
    assert console.act(aborted_code, "abort").status_code == 303

    html = console.get("/console/links").get_data(as_text=True)
    batches = re.findall(
        r'<tr data-batch="(\d)">.*?class="created-count">(\d+)</td><td class="opened-count">(\d+)',
        html,
        re.S,
    )
    assert batches == [("1", "3", "1"), ("2", "2", "1")]
    rows = list(csv.DictReader(io.StringIO(console.client.get("/console/links.csv").text)))
    assert [r["batch"] for r in rows] == ["batch 2"] * 2 + ["batch 1"] * 3  # newest first
    by_code = {r["code"]: r for r in rows}
    opened = [r for r in rows if r["opened"]]
    assert sorted(r["link"] for r in opened) == sorted([first[0], second[1]])
    assert {r["status"] for r in opened} == {"in_progress"}
    assert by_code[aborted_code]["status"] == "aborted" and not by_code[aborted_code]["opened"]
    assert all(r["created"] for r in rows)
    # Copy all: every link but the aborted one.
    usable = [link for link, flag in LINK.findall(html) if flag == "1"]
    assert len(usable) == 4 and by_code[aborted_code]["link"] not in usable


def test_the_links_page_costs_the_same_queries_for_5_or_60_participants(app, console) -> None:
    _batch(console, 5)
    with statements(app) as few:
        assert console.client.get("/console/links").status_code == 200
    with statements(app) as few_csv:
        assert console.client.get("/console/links.csv").status_code == 200
    for _ in range(11):
        _batch(console, 5)
    with statements(app) as many:
        html = console.client.get("/console/links").text
    with statements(app) as many_csv:
        assert console.client.get("/console/links.csv").status_code == 200
    assert html.count('class="copy"') == 60
    assert many["all"] == few["all"] <= 20, (few, many)
    assert many_csv["all"] == few_csv["all"] <= 20, (few_csv, many_csv)
