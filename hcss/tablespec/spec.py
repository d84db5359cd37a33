"""A table's contract: its columns in order, each with a type, a missing-value rule and a meaning.

Every table hcss writes or reads is declared once, as a :class:`TableSpec`.
The export, the simulation's outputs and the analysis take their columns
from it, and the data dictionary is rendered from it
(``python -m hcss.tablespec.dictionary``), so a column cannot change in one
place and not in the others.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Literal

#: The cell types of the dictionary: Parquet's string, int64, float64 and bool, and
#: "any" for a pattern column whose columns each take their own type (a parameter's).
Dtype = Literal["str", "int", "float", "bool", "any"]
DTYPES: tuple[Dtype, ...] = ("str", "int", "float", "bool", "any")


@dataclass(frozen=True)
class Column:
    """One column of a table.

    ``nullable`` is the missing-value rule: True when the cell may be empty
    (None or NaN, written as an empty cell), False when every row has a
    value. ``required`` marks the columns a reader refuses to go without:
    the ones `hcss analyze` reads. A ``pattern`` column stands for zero or
    more columns named at write time (a sweep's parameters, say); its name
    is a placeholder such as ``<parameter>``, its type ``any`` when each
    column takes its own (a parameter's) or one type all its columns share
    (the counts of a table with a column per status).
    """

    name: str
    dtype: Dtype
    description: str
    nullable: bool = True
    required: bool = False
    pattern: bool = False

    def __post_init__(self) -> None:
        if self.dtype not in DTYPES:
            raise ValueError(f"column {self.name!r}: unknown type {self.dtype!r}")
        if self.dtype == "any" and not self.pattern:
            raise ValueError(f"column {self.name!r}: only a pattern column has the type any")


@dataclass(frozen=True)
class TableSpec:
    """A table: its file name (without suffix), heading, prose and columns in order."""

    name: str
    title: str
    description: str
    columns: tuple[Column, ...]

    def __post_init__(self) -> None:
        names = [column.name for column in self.columns]
        if len(set(names)) != len(names):
            raise ValueError(f"table {self.name!r} names a column twice")

    @property
    def names(self) -> tuple[str, ...]:
        """The column names in order (a pattern column's placeholder included)."""
        return tuple(column.name for column in self.columns)

    @property
    def typed(self) -> tuple[tuple[str, Dtype], ...]:
        """(name, type) per column, the shape of the Parquet schema."""
        return tuple((column.name, column.dtype) for column in self.columns)

    @property
    def required(self) -> tuple[str, ...]:
        """The columns a reader of this table cannot go without."""
        return tuple(column.name for column in self.columns if column.required)

    def column(self, name: str) -> Column:
        for column in self.columns:
            if column.name == name:
                return column
        raise KeyError(f"table {self.name!r} has no column {name!r}")

    def expand(self, **patterns: Sequence[str]) -> tuple[str, ...]:
        """The column names with each pattern column replaced by the names given for it.

        ``expand(parameter=("message_rate", "quorum_k"))`` for the column
        ``<parameter>``; every pattern column must be given, and no other.
        """
        placeholders = {column.name.strip("<>") for column in self.columns if column.pattern}
        if set(patterns) != placeholders:
            raise ValueError(
                f"table {self.name!r} expands {sorted(placeholders)}, given {sorted(patterns)}"
            )
        expanded: list[str] = []
        for column in self.columns:
            if column.pattern:
                expanded.extend(patterns[column.name.strip("<>")])
            else:
                expanded.append(column.name)
        if len(set(expanded)) != len(expanded):
            raise ValueError(f"table {self.name!r}: a named column repeats a fixed one")
        return tuple(expanded)


def described(columns: Iterable[Column], descriptions: Mapping[str, str]) -> tuple[Column, ...]:
    """The columns with the given descriptions replacing theirs (one table's own wording)."""
    return tuple(
        replace(column, description=descriptions[column.name])
        if column.name in descriptions
        else column
        for column in columns
    )


class RowError(ValueError):
    """A row that breaks its table's contract; the message names the columns or the value."""


#: The Python types a cell of each type may hold (a bool is never a number here).
_PYTHON_TYPES: dict[Dtype, tuple[type, ...]] = {
    "str": (str,),
    "int": (int,),
    "float": (int, float),
    "bool": (bool,),
    "any": (object,),
}
#: A cell's type in words, as a refusal names it.
TYPE_WORDS: dict[Dtype, str] = {
    "str": "text",
    "int": "a whole number",
    "float": "a number",
    "bool": "true or false",
    "any": "a value",
}


def check_row(spec: TableSpec, row: Mapping[str, object], columns: Sequence[str]) -> None:
    """Raise RowError unless `row` has exactly `columns` of `spec`, each of its type and rule.

    One row as plain Python, before it is stored: every key a named column,
    every named column a key, a missing value (None or NaN) only where the
    rule allows it, and any other value of the column's type.
    """
    unknown = sorted(key for key in row if key not in columns)
    if unknown:
        raise RowError(f"a {spec.name} row has {unknown}, which its contract does not name")
    missing = [name for name in columns if name not in row]
    if missing:
        raise RowError(f"a {spec.name} row lacks {missing}, which its contract needs")
    for name in columns:
        column, value = spec.column(name), row[name]
        if value is None or (isinstance(value, float) and math.isnan(value)):
            if not column.nullable:
                raise RowError(
                    f"column {name!r} of a {spec.name} row is empty; the dictionary allows none"
                )
            continue
        number = column.dtype in ("int", "float")
        if not isinstance(value, _PYTHON_TYPES[column.dtype]) or (
            number and isinstance(value, bool)
        ):
            raise RowError(
                f"column {name!r} of a {spec.name} row holds {value!r}, "
                f"expected {TYPE_WORDS[column.dtype]}"
            )
