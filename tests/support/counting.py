"""Counting a table's rows, the measure most tests take of what a request stored or refused."""

from __future__ import annotations

from typing import Any

from flask import Flask
from sqlalchemy import func, select


def count_rows(app: Flask, model: Any) -> int:
    """The rows of `model`'s table in the app's database, read in a session of their own."""
    with app.extensions["hcss_db"].session_scope() as session:
        return int(session.scalar(select(func.count()).select_from(model)) or 0)
