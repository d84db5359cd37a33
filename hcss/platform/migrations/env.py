"""Alembic environment: the platform's metadata and its DATABASE_URL.

`hcss db upgrade` passes the URL in the Alembic config; a bare `alembic`
invocation falls back to the same rule the app uses (DATABASE_URL, else the
SQLite file in the instance folder).
"""

from __future__ import annotations

from alembic import context
from sqlalchemy import engine_from_config, pool

from hcss.platform.config import database_url
from hcss.platform.models import Base

config = context.config
target_metadata = Base.metadata


def _url() -> str:
    return config.get_main_option("sqlalchemy.url") or database_url()


def run_migrations_offline() -> None:
    context.configure(
        url=_url(),
        target_metadata=target_metadata,
        literal_binds=True,
        render_as_batch=True,
    )
    with context.begin_transaction():
        context.run_migrations()


def run_migrations_online() -> None:
    section = config.get_section(config.config_ini_section) or {}
    section["sqlalchemy.url"] = _url()
    connectable = engine_from_config(section, prefix="sqlalchemy.", poolclass=pool.NullPool)
    with connectable.connect() as connection:
        # Batch mode lets later revisions alter tables on SQLite too.
        context.configure(
            connection=connection, target_metadata=target_metadata, render_as_batch=True
        )
        with context.begin_transaction():
            context.run_migrations()


if context.is_offline_mode():
    run_migrations_offline()
else:
    run_migrations_online()
