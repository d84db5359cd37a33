"""The console's Alembic revision creates exactly the tables its models declare."""

from __future__ import annotations

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from alembic.script import ScriptDirectory
from sqlalchemy import MetaData, create_engine, inspect

from hcss.platform.cli import alembic_config
from hcss.platform.models import AuditRecord, Base, ConsoleAction, Experimenter
from tests.support.console import SECOND_FACTOR_COLUMNS, UNIQUE_TRIAL_KEYS

CONSOLE_TABLES = {m.__tablename__ for m in (Experimenter, ConsoleAction, AuditRecord)}
#: Columns later revisions add to tables that exist at 0002_console (table, column).
LATER_COLUMNS = SECOND_FACTOR_COLUMNS | {
    ("participant", "study"),  # 0004_c8_console
    ("probe_event", "latency_ms"),  # 0004_p8_idempotency
    ("interruption", "outage_s"),  # 0004_h13_hardening
    ("experimenter", "login_generation"),  # 0004_h13_hardening
    ("trial", "probe_counts"),  # 0005_a10_vocabularies
}


def _not_added_later(obj, name, type_, reflected, compare_to) -> bool:
    if type_ == "index":
        return name not in UNIQUE_TRIAL_KEYS
    return not (type_ == "column" and (obj.table.name, name) in LATER_COLUMNS)


def test_the_migrations_have_one_head() -> None:
    assert len(ScriptDirectory.from_config(alembic_config("sqlite://")).get_heads()) == 1


def test_upgrade_creates_the_console_tables_as_modelled_and_downgrade_removes_them(
    tmp_path,
) -> None:
    url = f"sqlite:///{tmp_path / 'migrated.sqlite3'}"
    config = alembic_config(url)
    command.upgrade(config, "0002_console")
    engine = create_engine(url)
    try:
        present = set(inspect(engine).get_table_names()) - {"alembic_version"}
        assert present >= CONSOLE_TABLES
        # Compare with every model the database should have by now (later revisions'
        # tables, such as the study engine's, are left out); any extra table shows too.
        expected = MetaData(naming_convention=Base.metadata.naming_convention)
        for table in Base.metadata.sorted_tables:
            if table.name in present | CONSOLE_TABLES:
                table.to_metadata(expected)
        with engine.connect() as connection:
            context = MigrationContext.configure(
                connection, opts={"include_object": _not_added_later}
            )
            assert compare_metadata(context, expected) == []
        command.downgrade(config, "0001")
        assert not CONSOLE_TABLES & set(inspect(create_engine(url)).get_table_names())
    finally:
        engine.dispose()
