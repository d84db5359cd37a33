"""What a running `hcss serve` tells the other commands and the experimenter's terminal.

`write_serving_file` records the server's address and default study in the
instance folder, so `hcss demo-trial` in another terminal prints a link on
the port the server really uses (`make run PORT=8080`) without being told.
`log_events_to_stderr` sends the participant event lines
(hcss.platform.console.eventlog) to the server's terminal.
"""

from __future__ import annotations

import json
import logging
import sys
from pathlib import Path
from typing import Any, TextIO
from urllib.parse import urlsplit

from hcss.platform.config import instance_path

SERVING_FILE = "serving.json"


def serving_path(port: int | None = None) -> Path:
    """The last server's file, or the file of the server on `port`."""
    return instance_path() / (SERVING_FILE if port is None else f"serving-{port}.json")


def write_serving_file(url: str, study: str) -> None:
    """The last server's address and study, and the same under its port: several servers
    run side by side (`make run PORT=8080 STUDY=demo` beside the protocol's)."""
    text = json.dumps({"url": url.rstrip("/"), "study": study}) + "\n"
    serving_path().write_text(text)
    port = urlsplit(url).port
    if port is not None:
        serving_path(port).write_text(text)


def read_serving_file(port: int | None = None) -> dict[str, Any]:
    """The last server's address and study (or the one on `port`'s); empty when none ran
    here or the file is unreadable."""
    try:
        data = json.loads(serving_path(port).read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def log_events_to_stderr(stream: TextIO | None = None) -> logging.Handler:
    """One line per participant event on the terminal: ``18:02:11 P1A2B3C4D stage 3 ...``."""
    handler = logging.StreamHandler(stream or sys.stderr)
    handler.setFormatter(logging.Formatter("%(asctime)s %(message)s", datefmt="%H:%M:%S"))
    logger = logging.getLogger("hcss.events")
    logger.setLevel(logging.INFO)
    logger.addHandler(handler)
    # Waitress gives the root logger a handler of its own (basicConfig): without
    # this, every event was printed a second time as "INFO:hcss.events:...".
    logger.propagate = False
    return handler
