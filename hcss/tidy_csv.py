"""The one CSV writer of hcss, with one rule for every cell.

The study export, the simulation's decisions, a sweep's cells, the
equivalence reference, the calibration's trials and the tables of `hcss
analyze` are all read by the same analysis, by R and by people in a
spreadsheet, so they are written alike (docs/data-dictionary.md):

- a missing value, None or a float NaN, is an empty cell, never ``nan``;
- a bool is ``true`` or ``false``;
- anything else is written as ``str`` gives it (a float in its shortest
  round-trip form);
- UTF-8, a header row, lines ending in CRLF (RFC 4180).

It imports nothing from hcss (nor pandas: a frame comes in through
:func:`write_frame`), so every package may use it; tests/test_tidy_csv.py
checks that no other module of hcss writes a CSV.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    import pandas as pd


def is_missing(value: object) -> bool:
    """None or a float NaN: the one meaning of "no value" (Parquet writes it as null)."""
    return value is None or (isinstance(value, float) and math.isnan(value))


def cell(value: object) -> object:
    """A value as its CSV cell."""
    if is_missing(value):
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    return value


class TableWriter:
    """Rows of named columns to an open text file; the header is written at once."""

    def __init__(self, handle: TextIO, columns: Sequence[str]) -> None:
        self.columns = tuple(columns)
        self._known = frozenset(self.columns)
        # A plain writer given lists: csv.DictWriter turns each dict into a list again
        # (a generator per row), a tenth of an export's time over 100,000 rows.
        self._writer = csv.writer(handle, lineterminator="\r\n")
        self._writer.writerow(self.columns)

    def write(self, row: Mapping[str, object]) -> None:
        """One row; a column it lacks is missing (empty), a key outside the columns an error."""
        if not self._known.issuperset(row):
            raise ValueError(f"columns not in the table: {sorted(set(row) - self._known)}")
        self._writer.writerow([cell(row.get(name)) for name in self.columns])


def write_rows(path: Path, columns: Sequence[str], rows: Iterable[Mapping[str, object]]) -> None:
    """Rows (mappings by column name) as the tidy CSV at `path` (its folder made when missing)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = TableWriter(handle, columns)
        for row in rows:
            writer.write(row)


def write_frame(path: Path, frame: pd.DataFrame) -> None:
    """A pandas frame as a table at `path`: its columns, its rows, the same cell rule.

    pandas' own ``to_csv`` would write ``True`` and LF line ends; here a
    missing value of any kind (None, NaN, ``pd.NA``, ``NaT``) is an empty cell
    and numpy scalars become the Python values they hold.
    """
    columns = [str(name) for name in frame.columns]
    if len(set(columns)) != len(columns):
        raise ValueError(f"a table names a column twice: {columns}")
    cells = frame.astype(object).where(frame.notna(), None)
    rows = cells.itertuples(index=False, name=None)
    write_rows(path, columns, (dict(zip(columns, row, strict=True)) for row in rows))
