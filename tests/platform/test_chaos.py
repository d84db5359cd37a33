"""Issue 44 §7: the chaos soak, 3.5 minutes of it, seeded (benchmarks/chaos.py).

Two `--cluster` processes behind the generated nginx on PostgreSQL, participant bots and
an experimenter's console over HTTP, and a nemesis of kill -9, SIGSTOP past the lease, a
database partition, a relay-level restart, a read-only database and a slow-client flood;
then all six invariants of benchmarks/chaos_check.py must hold (no 5xx but 503 with
Retry-After, nginx's own answers included; every bot participant at the debrief). The
seed is printed; the same seed gives the same faults (kind, process, length, in order; the
offsets move by a few seconds with the load), and a failing one reproduces with HCSS_CHAOS_SEED=<seed> (and HCSS_CHAOS_TEST_S for its length).
`make chaos` runs 30 minutes of the same.
"""

from __future__ import annotations

import os

import pytest

from benchmarks.chaos import SEED, print_run, run_chaos
from hcss.platform.serving.localserver import LocalNginx
from tests.support.databases import PG_ENV

pytestmark = pytest.mark.slow

#: Seconds of faults. The bots under way then finish their study (about 50 s) and the
#: checker reads the database: 180 s of faults took 3 min 45 s and 3 min 53 s in all at a
#: load of 5 on 2 cores; 150 s took 3 min 12 s (7 faults at seed 44: every kind but stop).
SECONDS = float(os.environ.get("HCSS_CHAOS_TEST_S", "150"))


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
    failed = {name: detail for name, (ok, detail) in result["verdicts"].items() if not ok}
    assert len(result["verdicts"]) == 6, result["verdicts"]
    assert not failed, (
        f"seed {SEED}: {failed}; reproduce: HCSS_CHAOS_SEED={SEED} HCSS_CHAOS_TEST_S={SECONDS:.0f}"
    )
    assert result["process_5xx"] == [], f"seed {SEED}: {result['process_5xx'][:10]}"
