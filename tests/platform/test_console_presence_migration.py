"""Revision 0004_c8_console: the head of the migrations builds exactly what the models declare."""

from __future__ import annotations

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import create_engine, inspect

from hcss.platform.cli import alembic_config
from hcss.platform.models import Base


def test_head_matches_the_models_and_0004_downgrades_cleanly(database_url: str) -> None:
    config = alembic_config(database_url)
    command.upgrade(config, "head")
    engine = create_engine(database_url)
    try:
        with engine.connect() as connection:
            assert compare_metadata(MigrationContext.configure(connection), Base.metadata) == []
        assert "participant_presence" in inspect(engine).get_table_names()
        command.downgrade(config, "0003_study")
        inspector = inspect(engine)
        assert "participant_presence" not in inspector.get_table_names()
        assert "study" not in {c["name"] for c in inspector.get_columns("participant")}
        command.upgrade(config, "head")  # and back up again, as a deploy after a rollback would
        assert "study" in {c["name"] for c in inspect(engine).get_columns("participant")}
    finally:
        engine.dispose()
