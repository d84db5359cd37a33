"""Audit rows as the console shows them: one typed shape for every kind of row.

`AuditRecord.row_counts` is JSON written by several actions (a withdrawal's
rows per table, an export's rows per table, a lockout's failure count), and
rows already stored may hold text there. The page renders `AuditEntry`, never
the JSON, so no stored row can break the console.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime
from typing import Any

from hcss.platform.models import AuditRecord


@dataclass(frozen=True)
class AuditEntry:
    created_at: datetime
    action: str
    experimenter: str
    participant_code: str
    #: Rows the action counted (withdrawn, exported); a lockout's failures; links refused.
    rows: int


def _count(value: Any) -> int:
    """A stored count, or 0 for anything that is not one (text, null, a bool, a list)."""
    return value if isinstance(value, int) and not isinstance(value, bool) else 0


def audit_entry(record: AuditRecord) -> AuditEntry:
    counts = record.row_counts if isinstance(record.row_counts, dict) else {}
    if record.action == "login_lockout":
        rows = _count(counts.get("failures"))
    elif record.action == "link_limit":  # the links asked for and refused
        rows = _count(counts.get("requested"))
    else:
        rows = sum(_count(value) for value in counts.values())
    return AuditEntry(
        created_at=record.created_at,
        action=str(record.action),
        experimenter=str(record.experimenter),
        participant_code=record.participant_code or "",
        rows=rows,
    )


def audit_entries(records: Iterable[AuditRecord]) -> list[AuditEntry]:
    return [audit_entry(record) for record in records]
