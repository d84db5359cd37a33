"""Power by resampling a pool: a case with a known answer, checked against R.

The golden powers are R 4.2's, by its own simulation of the exact
distribution (not by this package), with the R code beside each value.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from hcss.analysis import power as pw

CELL = ("decision_time_min", "overall")


def _shift_pool(shift: float, size: int = 20_000) -> pw.UnitPool:
    """Two simulation-only groups: N(0, 1) and N(shift, 1) as the quantiles of `size` equal
    slices, so the pool's shift is the shift exactly (a random pool of 20,000 was 0.98)."""
    normal = stats.norm.ppf((np.arange(size) + 0.5) / size).reshape(-1, 1)
    return pw.UnitPool((CELL,), {"M1SIM": normal, "M2SIM": normal + shift})


@pytest.mark.parametrize(
    ("n", "golden"),
    [
        # set.seed(1); mean(replicate(100000,
        #   wilcox.test(rnorm(12), rnorm(12, 1), exact = TRUE)$p.value < 0.05))
        (12, 0.60518),
        # set.seed(1); mean(replicate(100000,
        #   wilcox.test(rnorm(20), rnorm(20, 1), exact = TRUE)$p.value < 0.05))
        (20, 0.84845),
    ],
)
def test_mann_whitney_power_on_a_location_shift_matches_r(n: int, golden: float) -> None:
    """R's power lies in the Monte Carlo interval of ours. The seed is fixed, so the test is
    deterministic; a 95% interval misses the truth for about one seed in 20 (seed 99 with
    2,000 replications at n = 20: 0.8665 [0.851, 0.881]; seeds 1-5 with 1,000 each: 0.853
    on average), so a failure at another seed is first a question of luck, then of code."""
    replications = 2000
    counts = pw.rejections(_shift_pool(1.0), n, replications, seed=1)
    point = pw.PowerPoint(
        pw.Hypothesis("mann_whitney", *CELL, ("M1SIM", "M2SIM")),
        n,
        counts[pw.Hypothesis("mann_whitney", *CELL, ("M1SIM", "M2SIM"))],
        replications,
    )
    low, high = point.interval
    assert low <= golden <= high, (point.power, low, high)


def test_no_shift_rejects_about_alpha() -> None:
    replications = 600
    counts = pw.rejections(_shift_pool(0.0), 15, replications, seed=2)
    rejected = counts[pw.Hypothesis("mann_whitney", *CELL, ("M1SIM", "M2SIM"))]
    point = pw.PowerPoint(pw.Hypothesis("mann_whitney", *CELL), 15, rejected, replications)
    low, high = point.interval
    assert low <= 0.05 <= high


def test_a_pool_keeps_a_participants_trials_together() -> None:
    """Human groups are resampled by participant: row i of M1, M2 and M3 is one person."""
    rows = []
    for person in range(6):
        for group, offset in (("M1", 0.0), ("M2", 10.0), ("M3", 20.0)):
            rows.append(
                ("success_rate", "overall", group, "study", f"p{person}", "", person + offset)
            )
    measures = pd.DataFrame(
        rows, columns=["measure", "split", "group", "source", "unit", "participant", "value"]
    )
    pool = pw.unit_pool(measures)
    column = pool.cells.index(("success_rate", "overall"))
    m1, m2, m3 = (pool.values[g][:, column] for g in ("M1", "M2", "M3"))
    assert np.array_equal(m2 - m1, np.full(6, 10.0)) and np.array_equal(m3 - m1, np.full(6, 20.0))


def test_n_for_power_is_the_first_n_that_reaches_it() -> None:
    h = pw.Hypothesis("kruskal_wallis", *CELL)
    points = [pw.PowerPoint(h, n, k, 100) for n, k in ((12, 40), (20, 79), (28, 80), (40, 95))]
    assert pw.n_for_power(points) == {h: 28}
    assert pw.n_for_power(points[:2]) == {h: None}
