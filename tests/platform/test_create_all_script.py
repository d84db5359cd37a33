"""`Database.create_all` on a fresh PostgreSQL schema sends its DDL as one script (one round
trip instead of 112); the schema it makes must be the one SQLAlchemy's `create_all` and the
append-only triggers make statement by statement, which it still does on a schema that
already has tables (a test's restart) and on SQLite."""

from __future__ import annotations

import os
from typing import Any

import pytest
from sqlalchemy import create_engine, inspect, text

from hcss.platform.db import Database
from hcss.platform.models import Base
from hcss.platform.models.append_only import install_triggers
from hcss.platform.serving.localserver import postgres_schema
from tests.support.databases import PG_ENV


def schema_shape(url: str) -> dict[str, Any]:
    """Every table's columns, keys, indexes and constraints, and the schema's triggers."""
    engine = create_engine(url)
    try:
        inspector = inspect(engine)
        shape: dict[str, Any] = {}
        for table in sorted(inspector.get_table_names()):
            shape[table] = (
                [
                    (c["name"], str(c["type"]), c["nullable"], c["default"])
                    for c in inspector.get_columns(table)
                ],
                inspector.get_pk_constraint(table),
                sorted(map(repr, inspector.get_foreign_keys(table))),
                sorted(map(repr, inspector.get_indexes(table))),
                sorted(map(repr, inspector.get_unique_constraints(table))),
                sorted(map(repr, inspector.get_check_constraints(table))),
            )
        with engine.connect() as connection:
            shape["triggers"] = connection.execute(
                text(
                    "SELECT c.relname, t.tgname, replace(pg_get_triggerdef(t.oid), current_schema() || '.', '') "
                    "FROM pg_trigger t "
                    "JOIN pg_class c ON c.oid = t.tgrelid "
                    "WHERE NOT t.tgisinternal AND c.relnamespace = current_schema()::regnamespace "
                    "ORDER BY 1, 2"
                )
            ).all()
            shape["functions"] = connection.execute(
                text(
                    "SELECT proname, prosrc FROM pg_proc "
                    "WHERE pronamespace = current_schema()::regnamespace ORDER BY 1"
                )
            ).all()
        return shape
    finally:
        engine.dispose()


def test_the_one_script_makes_the_schema_create_all_makes_step_by_step(database_url: str) -> None:
    if not database_url.startswith("postgresql"):
        pytest.skip("the script is PostgreSQL's; SQLite creates statement by statement")
    database = Database(database_url)
    database.create_all()  # a fresh schema: the script
    database.engine.dispose()
    with postgres_schema(os.environ[PG_ENV], "hcss_test_steps") as stepwise_url:
        stepwise = create_engine(stepwise_url)
        Base.metadata.create_all(stepwise)
        with stepwise.begin() as connection:
            install_triggers(connection)
        stepwise.dispose()
        by_steps = schema_shape(stepwise_url)
    by_script = schema_shape(database_url)
    assert len(by_script["triggers"]) > 20 and set(Base.metadata.tables) <= set(by_script)
    assert by_script == by_steps


def test_a_second_create_all_on_the_same_schema_changes_nothing(database_url: str) -> None:
    database = Database(database_url)
    database.create_all()
    database.engine.dispose()
    first = schema_shape(database_url) if database_url.startswith("postgresql") else None
    again = Database(database_url)
    again.create_all()  # tables exist: statement by statement, each checked first
    again.engine.dispose()
    if first is not None:
        assert schema_shape(database_url) == first
