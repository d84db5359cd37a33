"""The nginx configuration that puts several `hcss serve` processes behind one address.

A live trial is hosted by one process at a time (hcss.platform.live.leases),
so every request of one participant should reach the same process: the
upstream hashes the participant's token, taken from the path of the study
pages (/p/<token>), the trial page (/live/<token>) and the live API and its
stream (/api/live/<token>/...). `consistent` (ketama) hashing moves only the
tokens of a process that leaves. Requests without a token (the console, study
links, static files) have an empty key, which nginx spreads round-robin.

When a process is down, or answers 503 because another process hosts the
trial (`HostedElsewhere`), nginx tries the next one. Commands are POSTs, so
`non_idempotent` lets nginx retry them too, but only those that carry an
Idempotency-Key: a process that did it once answers a repeat with the first
outcome. A POST without a key (a study page's form) goes through a location
that retries only what never reached a process (`error` before sending):
a form that committed on a dying process is not applied twice.

A process can also hang without closing anything (stopped, swapping, cut off
from its database): nginx connects, and waits for an answer. So the read
timeouts are short, and a timeout passes a request on to the next process
like an error: 15 s for pages and commands, and 3 s for the stream, which
sends a frame every half second while its trial runs (a silent stream is a
hung host; the page's watchdog opens a new one, which nginx sends on).

nginx sets X-Forwarded-Host and -Port itself: a client's own passed through, and
changed the links the console prints. The servers trust the X-Forwarded headers from
this proxy only when told (``HCSS_PROXY_HOPS=1`` and ``HCSS_TRUSTED_PROXY``, the
address nginx connects from; hcss.platform.serving.connections.proxy_adjustments).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

UPSTREAM = "hcss_processes"


def site_config(servers: Sequence[str], *, listen: str = "8080") -> str:
    """The `http {}` part: the token map, the upstream and the server (for conf.d/)."""
    if not servers:
        raise ValueError("name at least one hcss process (HOST:PORT)")
    # max_fails=0: a 503 from a process that does not host the trial must not mark that
    # process down (nginx counts every http_503 it passes on as a failure), or after a
    # kill the survivor is "down" too until fail_timeout, while it takes the trials over.
    members = "\n".join(f"    server {server} max_fails=0;" for server in servers)
    return f"""\
# Written by `hcss deploy nginx`: {len(servers)} hcss process(es), routed by participant token.
map $uri $hcss_token {{
    ~^/(?:p|live|api/live)/(?<token>[^/]+) $token;
    default "";
}}

# A request nginx must not send twice: a non-idempotent method without an Idempotency-Key.
map "$request_method:$http_idempotency_key" $hcss_unkeyed {{
    ~^(?:POST|PATCH|LOCK):$ 1;
    default "";
}}

upstream {UPSTREAM} {{
    hash $hcss_token consistent;
{members}
    keepalive 32;
}}

server {{
    listen {listen};
    client_max_body_size 256k;

    location / {{
        if ($hcss_unkeyed) {{
            return 418;
        }}
        error_page 418 = @unkeyed;
{_PROXY}
        location ~ ^/api/live/[^/]+/trials/[0-9]+/stream$ {{
            proxy_pass http://{UPSTREAM};
            proxy_read_timeout 3s;
        }}
        # A process that is down (or does not host the trial: 503) passes to the next;
        # a keyed command too, as its key makes a repeat harmless.
        proxy_next_upstream error timeout http_502 http_503 non_idempotent;
        proxy_next_upstream_tries {len(servers)};
        proxy_next_upstream_timeout 15s;
    }}

    location @unkeyed {{
{_PROXY}
        # Passed on only if no process got it (nginx never resends an unkeyed POST).
        proxy_next_upstream error timeout http_502 http_503;
        proxy_next_upstream_tries {len(servers)};
        proxy_next_upstream_timeout 15s;
    }}
}}
"""


#: The proxy settings of both locations.
_PROXY = f"""\
        proxy_pass http://{UPSTREAM};
        proxy_http_version 1.1;
        proxy_set_header Connection "";
        proxy_set_header Host $http_host;
        proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for;
        proxy_set_header X-Forwarded-Proto $scheme;
        # Set here, never a client's own: the server builds its links (links.csv) on them.
        proxy_set_header X-Forwarded-Host $http_host;
        proxy_set_header X-Forwarded-Port $server_port;

        # Server-Sent Events: every frame at once. A read timeout is the silence between
        # two reads, not a stream's length: a stream's frames come every half second, so
        # 3 s of silence is a hung process (pages and commands get 15 s).
        proxy_buffering off;
        proxy_cache off;
        proxy_read_timeout 15s;
        proxy_send_timeout 15s;
        proxy_connect_timeout 2s;"""


def standalone_config(servers: Sequence[str], *, listen: str, prefix: Path) -> str:
    """A whole nginx.conf that runs unprivileged in the foreground with its files under `prefix`.

    For tests, benchmarks and a trial run on one machine: `nginx -p PREFIX -c nginx.conf`.
    """
    temp = prefix / "temp"
    return f"""\
daemon off;
worker_processes 1;
pid {prefix / "nginx.pid"};
error_log {prefix / "error.log"} warn;
events {{ worker_connections 4096; }}
http {{
    access_log off;
    client_body_temp_path {temp / "body"};
    proxy_temp_path {temp / "proxy"};
    fastcgi_temp_path {temp / "fastcgi"};
    uwsgi_temp_path {temp / "uwsgi"};
    scgi_temp_path {temp / "scgi"};
{_indent(site_config(servers, listen=listen))}
}}
"""


def _indent(text: str) -> str:
    return "\n".join(("    " + line) if line else line for line in text.splitlines())
