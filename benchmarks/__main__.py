"""Run every benchmark and print its figures: `python -m benchmarks [simulation|live|console|analysis|study]`."""

from __future__ import annotations

import importlib
import sys

SUITES = ("simulation", "live", "live_processes", "console", "links", "analysis", "study")


def main(argv: list[str]) -> None:
    chosen = argv or list(SUITES)
    for name in chosen:
        if name not in SUITES:
            raise SystemExit(f"unknown benchmark {name!r}; choose from {', '.join(SUITES)}")
        try:
            suite = importlib.import_module(f"benchmarks.{name}")
        except ModuleNotFoundError as missing:
            if missing.name != f"benchmarks.{name}":
                raise
            print(f"== {name}: not available")
            continue
        print(f"== {name}")
        suite.run()


if __name__ == "__main__":
    main(sys.argv[1:])
