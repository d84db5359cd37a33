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

from hcss.tablespec.spec import Dtype, TableSpec

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
_TYPE_WORDS: dict[Dtype, str] = {
    "str": "text",
    "int": "a whole number",
    "float": "a number",
    "bool": "true or false",
    "any": "a value",
}


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


def _first_breach(spec: TableSpec, cases: pd.DataFrame) -> str:
    """The first failure pandera found, in the dictionary's words."""
    case = cases.iloc[0]
    name = str(case["column"]) if pd.notna(case["column"]) else ""
    if name not in spec.names:  # a column missing altogether (the check names it as the case)
        missing = str(case["failure_case"])
        return f"the {spec.name} table lacks column {missing!r}"
    column = spec.column(name)
    index = case["index"]
    row = f" in row {int(index) + 2}" if pd.notna(index) else ""
    value = case["failure_case"]
    if pd.isna(value) or str(case["check"]) == "not_nullable":
        return f"column {name!r} has an empty cell{row}; the dictionary allows none there"
    return f"column {name!r} holds {str(value)!r}{row}, expected {_TYPE_WORDS[column.dtype]}"
