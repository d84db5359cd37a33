"""The nginx configuration that puts several `hcss serve` processes behind one address.

A live trial is hosted by one process at a time (hcss.platform.live.leases),
so every request of one participant should reach the same process: the
upstream hashes the participant's token, taken from the path of the study
pages (/p/<token>), the trial page (/live/<token>) and the live API and its
stream (/api/live/<token>/...). It is nginx's plain `hash` (not the
`consistent` ring, which split two processes 54-59 %), and the processes
compute the same member for a token (hcss.platform.live.placement, with the
members in the order given here: set HCSS_GROUP to the same list), so a
trial is claimed where its participant arrives. Requests without a token
(the console, study links, static files) have an empty key, which nginx
spreads round-robin.

When a process is down, or answers 503 (its stream ceiling is reached, or a
trial is moving), nginx tries the next one. A process that gets a request
for a trial another member holds forwards it there: it answers
``X-Accel-Redirect: @hcss_<address>`` and nginx sends the same request (its
method and body too) through that member's named location below
(hcss.platform.live.forwarding); a forwarded request is marked (no
``X-Hcss-Forward``), so it is never forwarded twice. Commands are POSTs, so
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

Clients are bounded here, as a server facing the internet needs (the
processes behind see only nginx's connections): each address holds at most
`PER_CLIENT` connections (`limit_conn`, 429 beyond), and a client must send
a request's head and body, and read the answer, without long pauses
(`client_header_timeout`, `client_body_timeout`, `send_timeout`): a slowloris
is closed by nginx. The processes also count each client's requests in
progress by the forwarded address (hcss.platform.serving.connections).

When no process could answer (each was down, or stopped past its read timeout),
nginx does not answer its own 502 or 504: it answers 503 with Retry-After, the
same "not now" as a process's own 503 while the database is away, which the
page (static/live.js), the HTTP bots and a browser's please-wait page wait on
and send again (a command with the same Idempotency-Key; a form's repeat is
refused as already submitted, and a browser's page reloads with a GET). API
paths get JSON in the app's shape (`error`, `message`, `held_by`), pages a
please-wait page that reloads itself. Only nginx's own answers are replaced
(no `proxy_intercept_errors`): a process's 4xx and 503 pass unchanged.

The servers trust X-Forwarded-For and -Proto from this proxy only when told
(``HCSS_PROXY_HOPS=1`` and ``HCSS_TRUSTED_PROXY``, the address nginx connects
from; hcss.platform.serving.connections.proxy_adjustments). nginx sets
X-Forwarded-Host and -Port itself: a client's own passed through, and changed
the links the console prints.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

UPSTREAM = "hcss_processes"
#: Connections one client address may hold through nginx (as `hcss serve` caps it directly).
PER_CLIENT = 64
#: Seconds a client may pause while sending a request's head or body, or reading an answer.
CLIENT_HEADER_S = 10
CLIENT_BODY_S = 10
SEND_S = 15
#: Seconds nginx asks a client to wait when no process answered (its 503's Retry-After):
#: another may host the trial by now, so soon (the page asked again after 1 s of a 502/504).
PROCESS_LOST_RETRY_S = 1
#: The internal addresses of nginx's own 503 (a page, or JSON for the API).
LOST_PAGE, LOST_JSON = "/.hcss/process-lost.html", "/.hcss/process-lost.json"


def site_config(servers: Sequence[str], *, listen: str = "8080") -> str:
    """The `http {}` part: the token map, the upstream and the server (for conf.d/)."""
    if not servers:
        raise ValueError("name at least one hcss process (HOST:PORT)")
    # max_fails=0: a 503 from a process that does not host the trial must not mark that
    # process down (nginx counts every http_503 it passes on as a failure), or after a
    # kill the survivor is "down" too until fail_timeout, while it takes the trials over.
    members = "\n".join(f"    server {server} max_fails=0;" for server in servers)
    each = "".join(_member_upstream(index, server) for index, server in enumerate(servers))
    forwards = "".join(_member_locations(index, server) for index, server in enumerate(servers))
    group = ",".join(servers)
    return f"""\
# Written by `hcss deploy nginx`: {len(servers)} hcss process(es), routed by participant token.
# Start each process with HCSS_GROUP={group}
# (the same members in the same order: the processes place trials as nginx hashes).
map $uri $hcss_token {{
    ~^/(?:p|live|api/live)/(?<token>[^/]+) $token;
    default "";
}}

# A request nginx must not send twice: a non-idempotent method without an Idempotency-Key.
map "$request_method:$http_idempotency_key" $hcss_unkeyed {{
    ~^(?:POST|PATCH|LOCK):$ 1;
    default "";
}}

# Where nginx's own "no process answered" goes (its 502 and 504, answered as a 503).
map $uri $hcss_process_lost {{
    ~^/api/ {LOST_JSON};
    default {LOST_PAGE};
}}

upstream {UPSTREAM} {{
    hash $hcss_token;
{members}
    keepalive 32;
}}
{each}
limit_conn_zone $binary_remote_addr zone=hcss_clients:10m;

server {{
    listen {listen};
    client_max_body_size 256k;
    limit_conn hcss_clients {PER_CLIENT};
    limit_conn_status 429;
    client_header_timeout {CLIENT_HEADER_S}s;
    client_body_timeout {CLIENT_BODY_S}s;
    send_timeout {SEND_S}s;
    # No process answered: "not now" with Retry-After, never a 502 or 504 (see the top).
    # Recursive: a form's POST is already redirected once (418, @unkeyed below).
    error_page 502 504 =503 $hcss_process_lost;
    recursive_error_pages on;
{_process_lost()}
    location / {{
        if ($hcss_unkeyed) {{
            return 418;
        }}
        error_page 418 = @unkeyed;
        error_page 502 504 =503 $hcss_process_lost;
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
{forwards}}}
"""


def _process_lost() -> str:
    """nginx's own 503 with Retry-After, as JSON for the API and as a page that reloads."""
    message = (
        "The study server is not answering just now. Please wait: this page tries again "
        "by itself in a few seconds. "
        "Pages you finished earlier are saved; the page you had just sent may ask for its answers again."
    )
    body = json.dumps({"error": "server_unavailable", "message": message, "held_by": "server"})
    page = (
        '<!doctype html><html lang="en"><head><meta charset="utf-8">'
        f'<meta http-equiv="refresh" content="{PROCESS_LOST_RETRY_S}">'
        "<title>Please wait a moment</title></head><body><main><h1>Please wait a moment</h1>"
        f"<p>{message}</p><p>Error 503</p></main></body></html>"
    )
    return "".join(
        f"""
    location = {address} {{
        internal;
        default_type {kind};
        add_header Retry-After {PROCESS_LOST_RETRY_S} always;
        add_header Cache-Control no-store always;
        return 503 '{text}';
    }}
"""
        for address, kind, text in (
            (LOST_JSON, "application/json", body),
            (LOST_PAGE, "text/html", page),
        )
    )


def _member_upstream(index: int, server: str) -> str:
    """One member alone, for requests forwarded to it (kept-alive connections)."""
    return f"""
upstream hcss_member_{index} {{
    server {server};
    keepalive 4;
}}
"""


def _member_locations(index: int, server: str) -> str:
    """The named locations a process's X-Accel-Redirect sends a request to the trial's
    holder through (hcss.platform.live.forwarding): pages and commands, and streams."""
    proxy = _PROXY.replace(f"http://{UPSTREAM}", f"http://hcss_member_{index}").replace(
        f"proxy_set_header {FORWARD_HEADER} 1;", f'proxy_set_header {FORWARD_HEADER} "";'
    )
    return f"""
    location @hcss_{server} {{
{proxy}
        proxy_next_upstream off;
    }}

    location @hcss_{server}_stream {{
{proxy.replace("proxy_read_timeout 15s;", "proxy_read_timeout 3s;")}
        proxy_next_upstream off;
    }}
"""


#: The header a process's forwarding looks for (hcss.platform.live.forwarding.FORWARD_HEADER).
FORWARD_HEADER = "X-Hcss-Forward"

#: The proxy settings of both locations (and, sent to one member, of the forwarding ones).
_PROXY = f"""\
        proxy_pass http://{UPSTREAM};
        proxy_http_version 1.1;
        proxy_set_header Connection "";
        proxy_set_header Host $http_host;
        proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for;
        proxy_set_header X-Forwarded-Proto $scheme;
        proxy_set_header X-Hcss-Forward 1;
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
