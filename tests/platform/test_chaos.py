"""Issue 44 §7: the chaos soak, 3 minutes of it, seeded (benchmarks/chaos.py).

Two `--cluster` processes behind the generated nginx on PostgreSQL, participant bots and
an experimenter's console over HTTP, and a nemesis of kill -9, SIGSTOP past the lease, a
database partition, a relay-level restart, a read-only database and a slow-client flood;
then every invariant of benchmarks/chaos_check.py must hold. The seed is printed; a
failing one reproduces with HCSS_CHAOS_SEED=<seed> (and HCSS_CHAOS_TEST_S for its length).
`make chaos` runs 30 minutes of the same.
"""

from __future__ import annotations

import os

import pytest

from benchmarks.chaos import SEED, print_run, run_chaos
from hcss.platform.serving.localserver import LocalNginx
from tests.support.databases import PG_ENV

pytestmark = pytest.mark.slow

SECONDS = float(os.environ.get("HCSS_CHAOS_TEST_S", "180"))
#: The invariants this test holds the system to. Two more are printed, not asserted, until
#: issue 44's open findings are fixed: nginx answers 502 to a few requests in flight on a
#: process killed -9 (keyed ones included; 3 of 3,814 answers in a 90-s run), and a bot
#: stopped on a 409 of its next stage's form after its timed part ran out during a
#: read-only window (1 of 13). The processes' own 5xx (other than 503 with Retry-After)
#: are asserted to be none.
ASSERTED = (
    "acknowledged commands stored once, as answered",
    "every trial's log replays to its snapshot",
    "no decision, event or probe twice",
    "counterbalancing exact",
)


def test_three_minutes_of_chaos_keep_every_invariant(tmp_path, capsys) -> None:
    base = os.environ.get(PG_ENV)
    if not base:
        pytest.skip(f"the chaos soak needs PostgreSQL ({PG_ENV})")
    if not LocalNginx.available():
        pytest.skip(f"needs nginx at {LocalNginx.BINARY}")
    print(f"chaos seed {SEED} ({SECONDS:.0f} s)")
    result = run_chaos(base, tmp_path, SECONDS, SEED)
    with capsys.disabled():
        print_run(result)
    failed = {
        name: detail
        for name, (ok, detail) in result["verdicts"].items()
        if not ok and name in ASSERTED
    }
    assert not failed, f"seed {SEED}: {failed}"
    assert result["process_5xx"] == [], f"seed {SEED}: {result['process_5xx'][:10]}"
