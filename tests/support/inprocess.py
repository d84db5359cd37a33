"""Serve a test's own Flask app over HTTP on a loopback port, in a thread.

The browser tests that also drive the app from Python (bots moving a manual
clock, a scripted operator) need the browser and the test to share one app,
one runner and one clock, which a server subprocess cannot give.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager

from flask import Flask
from werkzeug.serving import make_server


@contextmanager
def serving(app: Flask) -> Iterator[str]:
    """The app's base URL while the block runs (threaded, 127.0.0.1 only)."""
    server = make_server("127.0.0.1", 0, app, threaded=True)
    thread = threading.Thread(target=server.serve_forever, name="test-http", daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_port}"
    finally:
        server.shutdown()
        thread.join(timeout=10)
        server.server_close()
