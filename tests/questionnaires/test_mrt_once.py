"""Issue 13 §6: after a (re)start, simultaneous first requests build the MRT bank once.

With `functools.cache` every thread that arrived before the first result was
stored built the figure catalogue itself (about 1.3 s of CPU each): 20
simultaneous requests stalled 9.5-10 s.
"""

from __future__ import annotations

import threading

from hcss.questionnaires.mrt import items, shapes
from hcss.questionnaires.mrt.protocol import mental_rotations_test


def test_twenty_simultaneous_first_calls_build_the_catalogue_once(monkeypatch) -> None:
    built = []
    real_splits = shapes._step_splits

    def counting_splits(total: int, parts: int):
        built.append(threading.get_ident())  # called once per catalogue build
        return real_splits(total, parts)

    monkeypatch.setattr(shapes, "_step_splits", counting_splits)
    expected = items.item_bank()
    shapes.figure_catalogue.reset()
    items._bank.reset()
    barrier = threading.Barrier(20)
    results = []

    def first_request() -> None:
        barrier.wait()
        results.append(items.item_bank() + items.practice_items())

    threads = [threading.Thread(target=first_request) for _ in range(20)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()

    assert len(built) == 1
    assert len(results) == 20 and all(r[: len(expected)] == expected for r in results)
    assert mental_rotations_test().max_score == len(expected)
