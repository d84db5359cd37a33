"""The Alembic head builds exactly the schema the ORM models declare.

`create_all()` serves the tests, `hcss db upgrade` serves real studies: if the two
drift apart, a study runs on a schema no test ever saw. Autogenerate against the
migrated database must find nothing to do, on SQLite and on PostgreSQL.
"""

from __future__ import annotations

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.migration import MigrationContext
from sqlalchemy import create_engine

from hcss.platform.cli import alembic_config
from hcss.platform.models import Base


def test_upgrade_to_head_matches_the_models(database_url: str) -> None:
    command.upgrade(alembic_config(database_url), "head")
    engine = create_engine(database_url)
    try:
        with engine.connect() as connection:
            context = MigrationContext.configure(connection, opts={"compare_type": True})
            assert compare_metadata(context, Base.metadata) == []
    finally:
        engine.dispose()
