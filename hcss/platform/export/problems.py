"""Rows the export cannot interpret: reported in `export_problems`, never fatal.

The export reads every participant's records in one pass. A single row that
cannot be read (a collective no trial has, a value of the wrong type, a
record a builder chokes on) must not cost the other rows, trials or
participants their export. Each such row is skipped, and a row of
`export_problems` says which record it was and why, so the analyst knows
exactly what is missing.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

#: The column types the export's Parquet schema uses, as Python types.
_PYTHON_TYPES: dict[str, tuple[type, ...]] = {
    "str": (str,),
    "int": (int,),
    "float": (int, float),
    "bool": (bool,),
}
_MAX_PROBLEM = 300
_INT64 = (-(2**63), 2**63 - 1)  # Parquet's int64

#: Types whose every value fits the column, checked first: `_fits` per value over an
#: export's million cells was a tenth of its time.
_PLAIN: dict[str, frozenset[type]] = {
    "str": frozenset({str}),
    "int": frozenset(),  # an int is checked against int64's range
    "float": frozenset({float}),
    "bool": frozenset({bool}),
}


def _fits(value: object, kind: str) -> bool:
    """Whether a value is of the column's type (no bool for a number, an int in int64)."""
    return (
        isinstance(value, _PYTHON_TYPES[kind])
        and (kind == "bool" or not isinstance(value, bool))
        and (not isinstance(value, int) or _INT64[0] <= value <= _INT64[1])
    )


class ProblemLog:
    """The `export_problems` rows of one export."""

    def __init__(self) -> None:
        self.rows: list[dict[str, Any]] = []

    def add(
        self, table: str, record: str, problem: str, *, participant: str | None, trial_id: Any
    ) -> None:
        self.rows.append(
            {
                "participant": participant,
                "trial_id": None if trial_id is None else str(trial_id),
                "table": table,
                "record": record,
                "problem": problem[:_MAX_PROBLEM],
            }
        )

    @contextmanager
    def guard(
        self, table: str, record: str, *, participant: str | None = None, trial_id: Any = None
    ) -> Iterator[None]:
        """Run a builder; any exception becomes a problem row instead of ending the export."""
        try:
            yield
        except Exception as error:  # noqa: BLE001 - the point is that nothing is fatal
            self.add(
                table,
                record,
                f"{type(error).__name__}: {error}",
                participant=participant,
                trial_id=trial_id,
            )

    def typed(
        self, table: str, schema: tuple[tuple[str, str], ...], rows: list[dict[str, Any]]
    ) -> list[dict[str, Any]]:
        """The rows whose every value fits its column's type; the others become problems."""
        kept = []
        for index, row in enumerate(rows):
            wrong = [
                name
                for name, kind in schema
                if (value := row.get(name)) is not None
                and type(value) not in _PLAIN[kind]
                and not _fits(value, kind)
            ]
            if wrong:
                self.add(
                    table,
                    f"row {index + 1}",
                    "values of the wrong type in " + ", ".join(wrong),
                    participant=row.get("participant"),
                    trial_id=row.get("trial_id"),
                )
            else:
                kept.append(row)
        return kept
