"""Where the platform finds its database and how fast live trials run.

Settings come from three layers, later ones winning: the defaults below, the
environment (``DATABASE_URL``, ``HCSS_INSTANCE_PATH``, ``HCSS_SECRET_KEY``,
``HCSS_TIME_ACCELERATION``), and the ``config`` mapping given to
``create_app``. Tests and bots use the mapping; deployments use the
environment.
"""

from __future__ import annotations

import os
import secrets
import sys
from pathlib import Path

from sqlalchemy.engine import make_url
from sqlalchemy.exc import ArgumentError


def default_instance_path() -> Path:
    """`instance/` of a source checkout, else Flask's place for an installed app.

    Absolute either way, so the database is the same file whichever directory
    `hcss` is started from: `<checkout>/instance` when running from a checkout
    (`make run`), `<sys.prefix>/var/hcss-instance` when installed from a wheel.
    """
    checkout = Path(__file__).resolve().parents[2]
    if (checkout / "pyproject.toml").is_file():
        return checkout / "instance"
    return Path(sys.prefix) / "var" / "hcss-instance"


def instance_path() -> Path:
    """The folder for the embedded database and the generated secret key."""
    configured = os.environ.get("HCSS_INSTANCE_PATH")
    path = Path(configured).resolve() if configured else default_instance_path()
    path.mkdir(parents=True, exist_ok=True)
    return path


def database_url() -> str:
    """``DATABASE_URL`` when set (PostgreSQL: ``postgresql+psycopg://...``), else SQLite."""
    configured = os.environ.get("DATABASE_URL")
    if configured:
        try:
            url = make_url(configured)
        except ArgumentError as error:
            raise ValueError(f"DATABASE_URL is not a database URL: {error}") from error
        if url.drivername in ("postgres", "postgresql"):
            # Heroku-style URLs name no driver (or an alias SQLAlchemy 2 dropped).
            url = url.set(drivername="postgresql+psycopg")
        return url.render_as_string(hide_password=False)
    return f"sqlite:///{instance_path() / 'hcss.sqlite3'}"


def secret_key() -> str:
    """A stable secret so sessions and CSRF tokens survive a server restart.

    Generated once into the instance folder unless ``HCSS_SECRET_KEY`` is set.
    """
    configured = os.environ.get("HCSS_SECRET_KEY")
    if configured:
        return configured
    key_file = instance_path() / "secret_key"
    if not key_file.exists():
        key_file.write_text(secrets.token_hex(32))
        key_file.chmod(0o600)
    return key_file.read_text().strip()


#: Starts through a public study link one client may send: (count, seconds); None: no limit.
JOIN_PER_CLIENT = (30, 600.0)


def parse_limit(text: str) -> tuple[int, float] | None:
    """``"30/600"`` -> (30, 600.0); ``"0"`` or ``""`` -> None (no limit)."""
    if not text or text.strip() == "0":
        return None
    count, _, seconds = text.partition("/")
    return int(count), float(seconds or 60)


def _join_limit() -> tuple[int, float] | None:
    configured = os.environ.get("HCSS_JOIN_PER_CLIENT")
    return JOIN_PER_CLIENT if configured is None else parse_limit(configured)


def _links_limit() -> tuple[int, float] | None:
    """Participant links one console account may create: (count, seconds), or None."""
    configured = os.environ.get("HCSS_LINKS_PER_EXPERIMENTER")
    return (500, 3600.0) if configured is None else parse_limit(configured)


def defaults() -> dict[str, object]:
    """The settings `create_app` starts from."""
    return {
        "DATABASE_URL": database_url(),
        "SECRET_KEY": None,  # filled lazily so tests never touch the instance folder
        "WTF_CSRF_TIME_LIMIT": None,  # a 20-minute trial page must still be able to POST
        # Trial time per wall-clock second. 1.0 in the study; tests and bots go faster.
        "TIME_ACCELERATION": float(os.environ.get("HCSS_TIME_ACCELERATION", "1.0")),
        # Start the background runner thread: only where trials are served (`hcss serve`
        # sets it). An app built for a script or a check has no thread; tests tick it.
        "LIVE_RUNNER": False,
        # Seconds of wall time between simulation snapshots of each live trial.
        "SNAPSHOT_INTERVAL_S": float(os.environ.get("HCSS_SNAPSHOT_INTERVAL_S", "5.0")),
        # Seconds between two stream frames when nothing changed (2 Hz floor).
        "STREAM_INTERVAL_S": 0.5,
        # Close a stream after this many wall seconds; EventSource reconnects by itself,
        # so this only bounds how long one waitress thread is held.
        "STREAM_MAX_S": 300.0,
        # Open live streams the server allows (each holds a thread); None: no ceiling.
        # `hcss serve` sets it to its thread count less a reserve for pages and the console.
        "MAX_STREAMS": None,
        # Streams per participant link; the newest takes over ("takeover" event).
        "STREAMS_PER_TOKEN": 1,
        # Streams one client address may hold; None: a quarter of MAX_STREAMS, at least 4
        # (HCSS_STREAMS_PER_CLIENT raises it for a lab whose participants share an address).
        "STREAMS_PER_CLIENT": int(os.environ.get("HCSS_STREAMS_PER_CLIENT", "0") or 0) or None,
        # Streams the participants of one study may hold; None: three quarters of MAX_STREAMS
        # (HCSS_STREAMS_PER_STUDY raises it for a server that runs one study at a time).
        "STREAMS_PER_STUDY": int(os.environ.get("HCSS_STREAMS_PER_STUDY", "0") or 0) or None,
        # Session cookies: not sent on cross-site subrequests; Secure whenever the request
        # came over HTTPS (directly, or as the trusted proxy says), and always with
        # HCSS_SECURE_COOKIES=1.
        "SESSION_COOKIE_SAMESITE": "Lax",
        "SESSION_COOKIE_HTTPONLY": True,
        "SESSION_COOKIE_SECURE": os.environ.get("HCSS_SECURE_COOKIES", "") == "1",
        "REMEMBER_COOKIE_SAMESITE": "Lax",
        "REMEMBER_COOKIE_HTTPONLY": True,
        "REMEMBER_COOKIE_SECURE": os.environ.get("HCSS_SECURE_COOKIES", "") == "1",
        # Reverse proxies in front of the server that set X-Forwarded-For/-Proto/-Host
        # (werkzeug's ProxyFix trusts that many hops); 0: the headers are ignored, so a
        # visitor cannot forge their address. Behind the README's nginx set HCSS_PROXY_HOPS=1.
        "PROXY_HOPS": int(os.environ.get("HCSS_PROXY_HOPS", "0") or 0),
        # A group's members ("host:port", comma-separated) in the order `hcss deploy nginx`
        # was given them (`hcss serve --processes` sets it for its workers): trials are
        # placed where nginx sends their participants, and a request for a trial held by
        # another member is forwarded there (hcss.platform.live.placement); empty: neither.
        "GROUP_MEMBERS": [
            m.strip() for m in os.environ.get("HCSS_GROUP", "").split(",") if m.strip()
        ],
        # The address the nearest proxy connects from (waitress trusts its headers only
        # from there; "*": any peer); `hcss deploy nginx` on this host is 127.0.0.1.
        # Every per-client limit counts an IPv4 address by this prefix (32: each address;
        # 24: its /24) and an IPv6 address by its /64 (hcss.platform.guards.clients).
        "CLIENT_PREFIX_V4": int(os.environ.get("HCSS_CLIENT_PREFIX_V4", "32") or 32),
        # Pages send no Referer (Referrer-Policy: no-referrer: links carry tokens), so
        # Flask-WTF's HTTPS-only Referer check would refuse every form behind a TLS proxy
        # now that the proxy's scheme reaches the app; the CSRF token and SameSite=Lax
        # cookies are the protection.
        "WTF_CSRF_SSL_STRICT": False,
        "TRUSTED_PROXY": os.environ.get("HCSS_TRUSTED_PROXY", "127.0.0.1").strip() or "127.0.0.1",
        # Networks (CIDR, comma-separated in HCSS_CONSOLE_ALLOW) whose console sign-ins are
        # never throttled: the lab's own way in while a guesser is locked out.
        "CONSOLE_ALLOW": [
            network.strip()
            for network in os.environ.get("HCSS_CONSOLE_ALLOW", "").split(",")
            if network.strip()
        ],
        # Starts of the public study link one address may send: (count, seconds), or
        # None; HCSS_JOIN_PER_CLIENT="30/600" (hcss.platform.guards.ratelimit).
        "JOIN_PER_CLIENT": _join_limit(),
        # Participant links one console account may create: (count, seconds), or None;
        # HCSS_LINKS_PER_EXPERIMENTER="500/3600" (hcss.platform.console.link_limit).
        "LINKS_PER_EXPERIMENTER": _links_limit(),
        # Bytes of request body (Flask answers 413 past it; `hcss serve` tells waitress too).
        # The largest legitimate body, a questionnaire page, is a few kB.
        "MAX_CONTENT_LENGTH": 256 * 1024,
    }
