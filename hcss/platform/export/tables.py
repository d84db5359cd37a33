"""The export's tables and their column types, read from their contracts in hcss.tablespec.

The columns, their types and their order are declared once, in
`hcss.tablespec` (the data dictionary is rendered from the same specs); this
module gives the export's view of them. The types choose the Parquet schema;
CSV writes every type as text.
"""

from __future__ import annotations

from hcss.tablespec import EXPORT_TABLES, Dtype
from hcss.tablespec.export import DEMOGRAPHICS, MODELS

__all__ = ["DEMOGRAPHICS", "MODELS", "PROBLEMS_TABLE", "TABLES", "TRIAL_TABLES", "columns"]

#: (column, type) per table, in the dictionary's order.
TABLES: dict[str, tuple[tuple[str, Dtype], ...]] = {
    name: spec.typed for name, spec in EXPORT_TABLES.items()
}

#: Records the export could not read; see hcss.platform.export.problems.
PROBLEMS_TABLE = "export_problems"

#: Tables of what happens inside a trial; training trials get their own copies.
TRIAL_TABLES = ("decisions", "requests", "observations", "probes")


def columns(table: str) -> tuple[str, ...]:
    return EXPORT_TABLES[table].names
