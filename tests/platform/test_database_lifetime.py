"""A `Database` nobody holds any more is freed, with its engine, pool and compiled statements.

Every test, CLI command and benchmark makes one; a process that kept each one alive grew
by tens of thousands of objects per test module (SQLAlchemy's statement caches of every
engine), and each garbage collection of a test worker late in the suite took 3-4 s.
"""

from __future__ import annotations

import gc
import weakref

from sqlalchemy import select

from hcss.platform.db import Database
from hcss.platform.models import Participant


def test_a_database_dropped_after_use_is_freed(tmp_path) -> None:
    database = Database(f"sqlite:///{tmp_path / 'lifetime.sqlite3'}")
    database.create_all()
    with database.session_scope() as session:  # the session's events have fired
        session.scalars(select(Participant)).all()
    gone = weakref.ref(database)
    engine = weakref.ref(database.engine)
    database.engine.dispose()
    del database, session
    gc.collect()
    assert gone() is None and engine() is None
