"""Study load benchmark: N participant bots walk the whole demo study at once over HTTP.

One waitress server in its own process (SQLite, WAL) runs the demo study at
time acceleration 20; `hcss.platform.bots.http_load` walks N bots through every
page, questionnaire, MRT part and live trial concurrently, as browsers
would. Figures: bots completed and failed, answers >= 500, the page and
live-API latency percentiles, the routes that make up the slow tail, and the
CPU the server and the bots used (they share the machine). Loopback only;
bounded in count and time.
"""

from __future__ import annotations

import resource
from pathlib import Path
from tempfile import TemporaryDirectory

from benchmarks.live import _process_cpu_s
from benchmarks.live_processes import database_base_url, group
from hcss.platform.bots.http_load import percentile, run_http_bots
from hcss.platform.cli import upgrade_database
from hcss.platform.serving.localserver import LocalNginx, LocalServer, postgres_schema

BOT_COUNTS = (8, 24)
#: The issue's figure for several processes: 24 bots through nginx, 1 process against 2.
CLUSTER_BOTS = 24
ACCELERATION = 20.0
TARGET_PAGE_P95_MS = 500.0


def _cpu_s(who: int) -> float:
    usage = resource.getrusage(who)
    return usage.ru_utime + usage.ru_stime


def run() -> None:
    with TemporaryDirectory() as tmp:
        for count in BOT_COUNTS:
            url = f"sqlite:///{Path(tmp) / f'study-{count}.sqlite3'}"
            upgrade_database(url)
            env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": str(ACCELERATION)}
            server_before = _cpu_s(resource.RUSAGE_CHILDREN)
            with LocalServer(
                url, Path(tmp) / f"instance-{count}", threads=64, extra_env=env
            ) as server:
                bots_before = _cpu_s(resource.RUSAGE_SELF)
                figures = run_http_bots(server.url, url, "demo", count, concurrency=count)
                bots_s = _cpu_s(resource.RUSAGE_SELF) - bots_before
            # A child's CPU is counted once it has exited: the server's, start included.
            server_s = _cpu_s(resource.RUSAGE_CHILDREN) - server_before
            ok = not figures.errors and percentile(figures.page_ms, 95) < TARGET_PAGE_P95_MS
            print(f"    {figures.summary()}  {'ok' if ok else 'below target'}")
            print(
                f"      CPU: server {server_s:.1f} s (with its start), bots {bots_s:.1f} s, "
                f"over {figures.wall_s:.1f} s of walking (2 cores: {2 * figures.wall_s:.0f} s)"
            )
            for line in figures.slowest_routes():
                print(f"      slow: {line}")
            for error in figures.errors[:5]:
                print(f"      failed: {error}")
    through_nginx()
    print(
        f"(5) study load: concurrent bots through the demo study over HTTP, "
        f"page p95 target < {TARGET_PAGE_P95_MS:.0f} ms, 0 errors"
    )


def through_nginx() -> None:
    """The same walk on PostgreSQL through nginx: one `--cluster` process, then two.

    Both runs differ only in the number of processes (same database server,
    nginx configuration, bots and acceleration), so their page latencies show
    what a second process buys on this machine. The bots share its two cores.
    """
    base = database_base_url()
    if base is None or not LocalNginx.available():
        print("    through nginx: skipped (needs HCSS_BENCH_DATABASE_URL or nginx)")
        return
    env = {"HCSS_STUDY": "demo", "HCSS_TIME_ACCELERATION": str(ACCELERATION)}
    with TemporaryDirectory() as tmp:
        for processes in (1, 2):
            with postgres_schema(base, "hcss_bench_study") as url:
                upgrade_database(url)
                workdir = Path(tmp) / f"study-{processes}"
                with group(url, processes, workdir, extra_env=env) as (servers, nginx):
                    pids = [s.process.pid for s in servers if s.process is not None]
                    cpu_before = sum(_process_cpu_s(pid) for pid in pids)
                    figures = run_http_bots(
                        nginx.url, url, "demo", CLUSTER_BOTS, concurrency=CLUSTER_BOTS
                    )
                    server_s = sum(_process_cpu_s(pid) for pid in pids) - cpu_before
            ok = not figures.errors and percentile(figures.page_ms, 95) < TARGET_PAGE_P95_MS
            print(
                f"    PostgreSQL via nginx, {processes} process(es): {figures.summary()}  "
                f"{'ok' if ok else 'below target'}"
            )
            print(f"      CPU: servers {server_s:.1f} s over {figures.wall_s:.1f} s of walking")
            for error in figures.errors[:5]:
                print(f"      failed: {error}")
