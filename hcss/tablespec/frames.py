"""Frames checked against their table's contract, with pandera.

A reader that has a table as a pandas frame asks :func:`check` whether the
frame keeps its spec: every spec column present, each value of its type
(an int column holds whole numbers, a float column numbers, a bool column
booleans) and no empty cell in a column whose rule is "never". pandera does
the checking; :class:`ContractError` says the first breach in words for the
person who gave the file, with the row as a spreadsheet counts it (header =
row 1).

Only readers of frames import this module (pandera and pandas load with it);
the specs themselves stay plain Python.
"""

from __future__ import annotations

from collections.abc import Sequence
from functools import cache

import pandas as pd
import pandera.errors
import pandera.pandas as pa

from hcss.tablespec.spec import TYPE_WORDS, Dtype, TableSpec

#: pandas dtype each cell type is coerced to for the check; str and pattern columns
#: keep theirs (a text cell may read as a number, and is still text). An int column
#: is coerced to floats and checked whole: a CSV column with a gap reads as floats.
_PANDAS_DTYPES: dict[Dtype, str | None] = {
    "str": None,
    "int": "Float64",
    "float": "Float64",
    "bool": "boolean",
    "any": None,
}
_WHOLE = pa.Check(
    lambda values: values.isna() | ((values.abs() < 2**63) & (values % 1 == 0).fillna(False)),
    name="whole",
)


#: A text cell of a table hcss writes holds text, not a number that happens to fit.
_TEXT = pa.Check(lambda value: isinstance(value, str), element_wise=True, name="text")


class ContractError(ValueError):
    """A frame that breaks its table's contract; the message names column, value and row."""


@cache
def schema(spec: TableSpec, columns: tuple[str, ...] | None = None) -> pa.DataFrameSchema:
    """The pandera schema of `spec` (or of the named columns of it); other columns pass."""
    chosen = spec.columns if columns is None else tuple(spec.column(name) for name in columns)
    return pa.DataFrameSchema(
        {
            column.name: pa.Column(
                _PANDAS_DTYPES[column.dtype],
                nullable=column.nullable,
                checks=[_WHOLE] if column.dtype == "int" else [],
                coerce=_PANDAS_DTYPES[column.dtype] is not None,
            )
            for column in chosen
            if not column.pattern
        },
        strict=False,
        name=spec.name,
    )


def check(frame: pd.DataFrame, spec: TableSpec, columns: Sequence[str] | None = None) -> None:
    """Raise ContractError unless `frame` keeps the contract of `spec` (or of `columns` of it).

    The frame itself is left as it is: the check coerces a copy.
    """
    names = None if columns is None else tuple(columns)
    try:
        schema(spec, names).validate(frame, lazy=True)
    except pandera.errors.SchemaErrors as errors:
        raise ContractError(_first_breach(spec, errors.failure_cases)) from None


def _first_breach(spec: TableSpec, cases: pd.DataFrame, patterned: tuple[str, ...] = ()) -> str:
    """The first failure pandera found, in the dictionary's words.

    `patterned` names the frame's columns that a pattern column of `spec` stands for.
    """
    case = cases.iloc[0]
    name = str(case["column"]) if pd.notna(case["column"]) else ""
    if name not in spec.names and name not in patterned:
        # a column missing altogether (the check names it as the case)
        missing = str(case["failure_case"])
        return f"the {spec.name} table lacks column {missing!r}"
    column = (
        spec.column(name)
        if name in spec.names
        else next(column for column in spec.columns if column.pattern)
    )
    index = case["index"]
    row = f" in row {int(index) + 2}" if pd.notna(index) else ""
    value = case["failure_case"]
    if pd.isna(value) or str(case["check"]) == "not_nullable":
        return f"column {name!r} has an empty cell{row}; the dictionary allows none there"
    return f"column {name!r} holds {str(value)!r}{row}, expected {TYPE_WORDS[column.dtype]}"


def conform(frame: pd.DataFrame, spec: TableSpec, name: str | None = None) -> pd.DataFrame:
    """`frame` as its table is written: the spec's columns in the spec's order, every cell checked.

    The writer's check, stricter than a reader's: a column the spec does not
    name (and no pattern column of it takes) is refused, as is a missing
    column whose rule is "never" and a cell of another type, text included
    (a text column holds text). A column whose rule is "allowed" may be left
    out, as when the inputs lack it. The other columns of the frame are the
    pattern column's, checked with its type. `name` is the table as written
    (`descriptive_success_rate` for the spec `descriptive_<measure>`).
    Raise ContractError naming the table, the column and, for a cell, its
    row as the CSV counts it (header = row 1).
    """
    table = name or spec.name
    names = [str(column) for column in frame.columns]
    fixed = {column.name for column in spec.columns if not column.pattern}
    patterns = [column for column in spec.columns if column.pattern]
    others = [column for column in names if column not in fixed]
    if others and len(patterns) != 1:
        raise ContractError(
            f"table {table!r} has column {others[0]!r}, which its contract "
            f"(hcss.tablespec, table {spec.name!r}) does not name"
        )
    for column in spec.columns:
        if not column.pattern and not column.nullable and column.name not in names:
            raise ContractError(
                f"table {table!r} lacks column {column.name!r}, which its contract needs"
            )
    order: list[str] = []
    for column in spec.columns:
        if column.pattern:
            order += others
        elif column.name in names:
            order.append(column.name)
    written = frame.set_axis(names, axis="columns")[order]
    try:
        _written_schema(spec, tuple(order)).validate(written.reset_index(drop=True), lazy=True)
    except pandera.errors.SchemaErrors as errors:
        breach = _first_breach(spec, errors.failure_cases, tuple(others))
        raise ContractError(f"table {table!r} breaks its contract: {breach}") from None
    return written


@cache
def _written_schema(spec: TableSpec, names: tuple[str, ...]) -> pa.DataFrameSchema:
    """The writer's schema of `spec` for the columns `names` (a pattern column's by its type)."""
    columns = {}
    for name in names:
        column = (
            spec.column(name)
            if name in spec.names
            else next(column for column in spec.columns if column.pattern)
        )
        pandas_dtype = _PANDAS_DTYPES[column.dtype]
        checks = {"int": [_WHOLE], "str": [_TEXT]}.get(column.dtype, [])
        columns[name] = pa.Column(
            pandas_dtype, nullable=column.nullable, checks=checks, coerce=pandas_dtype is not None
        )
    return pa.DataFrameSchema(columns, strict=True, name=spec.name)
