"""Run every benchmark and print its figures: `python -m benchmarks [suite [part ...] ...]`.

A suite with parts (`live_processes`: capacity, failover, survivor) runs only
the parts named after it: `python -m benchmarks live_processes failover`.
"""

from __future__ import annotations

import importlib
import sys

SUITES = (
    "simulation",
    "live",
    "live_processes",
    "console",
    "export",
    "links",
    "analysis",
    "study",
    "plan",
    "chaos",
)


def main(argv: list[str]) -> None:
    chosen: list[tuple[str, list[str]]] = []
    for word in argv:
        if word in SUITES:
            chosen.append((word, []))
        elif chosen:
            chosen[-1][1].append(word)  # a part of the suite before it
        else:
            raise SystemExit(f"unknown benchmark {word!r}; choose from {', '.join(SUITES)}")
    for name, parts in chosen or [(name, []) for name in SUITES]:
        try:
            suite = importlib.import_module(f"benchmarks.{name}")
        except ModuleNotFoundError as missing:
            if missing.name != f"benchmarks.{name}":
                raise
            print(f"== {name}: not available")
            continue
        print(f"== {name}" + (f" ({', '.join(parts)})" if parts else ""))
        if parts:
            suite.run(parts)
        else:
            suite.run()


if __name__ == "__main__":
    main(sys.argv[1:])
