"""SQLite that was read-only takes writes again once its file does, without a restart.

SQLite keeps one `-shm` mapping per database file per process, shared by every
connection of the process to that file, and maps it read-only when the file
is (a read-only mount, a start on a read-only disk). The mapping stays
read-only while any connection of the process keeps it, and a connection
opened meanwhile joins it: replacing connections one at a time, as the pool
does after a read-only error, never let a writable one in, and a server that
started on a read-only disk answered 503 to every write for good once the
disk was writable again (issue 30 §3).

So a connection opened while the file refuses writes, or beside such a
connection (it shares the mapping), is marked and is never pooled: it is
closed when handed back. Once the file is writable, a new connection waits
(at most `RETIRE_WAIT_S`) for the marked ones still in use to be handed back,
and then opens a fresh, writable mapping. While the file stays read-only this
costs one SQLite open per checkout; a writable file costs one flag check.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

from sqlalchemy import Engine, event

#: The pool entry's mark: opened while the file refused writes, or beside one that was.
MARK = "hcss_read_only_mapping"
#: How long a new connection waits for the marked ones in use to be handed back.
RETIRE_WAIT_S = 5.0


class ReadOnlyMappings:
    """The marked connections of one SQLite file and the wait for the last one to close."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.open = 0
        self._changed = threading.Condition()

    def file_writable(self) -> bool:
        """Whether the file (or, before it exists, its directory) takes writes now."""
        target = self.path if self.path.exists() else self.path.parent
        return os.access(target, os.W_OK)

    def before_connect(self, *_args: Any) -> None:
        with self._changed:
            if self.open and self.file_writable():
                self._changed.wait_for(lambda: self.open == 0, timeout=RETIRE_WAIT_S)

    def connected(self, _dbapi_connection: Any, record: Any) -> None:
        with self._changed:
            if self.open or not self.file_writable():
                record.info[MARK] = True
                self.open += 1

    def closing(self, _dbapi_connection: Any, record: Any) -> None:
        if record.info.pop(MARK, False):
            with self._changed:
                self.open -= 1
                self._changed.notify_all()

    def checked_in(self, _dbapi_connection: Any, record: Any) -> None:
        if record.info.get(MARK):
            record.invalidate()  # closes it: the next checkout opens a new connection


def install(engine: Engine, path: Path) -> ReadOnlyMappings:
    """Mark, retire and wait on `engine`'s connections as the module docstring says."""
    mappings = ReadOnlyMappings(path)
    event.listen(engine, "do_connect", mappings.before_connect)
    event.listen(engine, "connect", mappings.connected)
    event.listen(engine, "close", mappings.closing)
    event.listen(engine, "checkin", mappings.checked_in)
    return mappings
