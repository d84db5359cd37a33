"""A stand-in for MTurk on this machine: its worker page frames a HIT, its externalSubmit records.

MTurk shows an ExternalQuestion as an iframe of the study's URL, with
`workerId`, `assignmentId`, `hitId` and `turkSubmitTo` appended, and takes the
answer as a form posted to `turkSubmitTo` + `/mturk/externalSubmit`. This
server does both on `http://localhost:<port>`, a different *site* from the
study's `http://127.0.0.1:<port>` (so the browser treats the frame as
cross-site, as it does on MTurk: no cookies go to the framed study). A study
names it in its file (`[online] mturk_origins`), the way a study names MTurk.

MTurk answers an externalSubmit with a redirect to another of its hosts (the worker site);
`redirect_to` plays that: the post is recorded, then answered with a 302 to that origin's
`/submitted`, a page every stand-in serves.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from html import escape
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qs


@dataclass
class MTurkStandIn:
    """The stand-in's address, the HIT URL its worker page frames, and the posts it received."""

    origin: str
    hit_url: str = ""
    redirect_to: str = ""
    submissions: list[dict[str, list[str]]] = field(default_factory=list)

    def worker_page(self) -> str:
        return f"{self.origin}/worker"


@contextmanager
def mturk_standin() -> Iterator[MTurkStandIn]:
    standin = MTurkStandIn(origin="")

    class Handler(BaseHTTPRequestHandler):
        def log_message(self, *args: object) -> None:  # quiet
            pass

        def _answer(self, body: str) -> None:
            data = body.encode()
            self.send_response(200)
            self.send_header("Content-Type", "text/html; charset=utf-8")
            self.send_header("Content-Length", str(len(data)))
            self.end_headers()
            self.wfile.write(data)

        def do_GET(self) -> None:
            if self.path == "/submitted":  # where MTurk's redirect after a submission lands
                self._answer("<p id='submitted'>HIT submitted</p>")
                return
            # MTurk's worker page: the HIT in an iframe of FrameHeight.
            self._answer(
                f'<h1>HIT</h1><iframe id="hit" src="{escape(standin.hit_url)}" '
                'width="100%" height="500"></iframe>'
            )

        def do_POST(self) -> None:
            length = int(self.headers.get("Content-Length", "0"))
            form = parse_qs(self.rfile.read(length).decode())
            if self.path == "/mturk/externalSubmit":
                standin.submissions.append(form)
                if standin.redirect_to:
                    self.send_response(302)
                    self.send_header("Location", f"{standin.redirect_to}/submitted")
                    self.send_header("Content-Length", "0")
                    self.end_headers()
                    return
                self._answer("<p id='submitted'>HIT submitted</p>")
            else:
                self.send_error(404)

    server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    standin.origin = f"http://localhost:{server.server_port}"
    thread = threading.Thread(target=server.serve_forever, name="mturk-standin", daemon=True)
    thread.start()
    try:
        yield standin
    finally:
        server.shutdown()
        thread.join(timeout=10)
        server.server_close()
