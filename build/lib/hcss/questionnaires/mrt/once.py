"""Build an expensive, argument-free value once, even when many threads ask at the same moment.

`functools.cache` lets every caller that arrives before the first result is
stored compute it too: after a (re)start, the first 20 simultaneous requests
each built the MRT figure catalogue (about 1.3 s of CPU each) and stalled
9.5-10 s. `built_once` makes the later callers wait for the first one's
result instead; `hcss serve` also builds the bank before it takes requests.
"""

from __future__ import annotations

import functools
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

T = TypeVar("T")


class BuiltOnce(Generic[T]):
    """A zero-argument function whose result is computed once, under a lock."""

    def __init__(self, build: Callable[[], T]) -> None:
        functools.update_wrapper(self, build)
        self._build = build
        self._lock = threading.Lock()
        self._built: list[T] = []  # empty until built; a list so None could be a result

    def __call__(self) -> T:
        if not self._built:
            with self._lock:
                if not self._built:
                    self._built.append(self._build())
        return self._built[0]

    def reset(self) -> None:
        """Forget the result (tests)."""
        with self._lock:
            self._built.clear()


def built_once(build: Callable[[], T]) -> BuiltOnce[T]:
    return BuiltOnce(build)
