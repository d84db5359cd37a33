"""`make bench`'s console suite stays runnable: one poll of the live table, timed as the
/console/progress.json view answers it, at a small size."""

from __future__ import annotations

from benchmarks import console as bench


def test_the_console_benchmark_times_a_poll_of_the_table(monkeypatch, capsys) -> None:
    monkeypatch.setattr(bench, "PARTICIPANTS", 30)
    monkeypatch.setattr(bench, "POLLS", 2)
    bench.run()
    printed = capsys.readouterr().out
    assert "console table, 30 participants (SQLite): one poll median" in printed
    assert "page 1 of 2" in printed  # 25 a page
