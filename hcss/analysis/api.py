"""hcss's tests for a notebook: a long-format DataFrame in, a tidy DataFrame out.

Each function takes the data as pingouin does (one row per observation,
columns named by ``dv``, ``between``, ``within`` and ``subject``) and
returns one row per test or per pair, with the statistic, p, effect size,
its 95% interval and the variant used. The computations are the report's
own (:mod:`stats`, :mod:`repeated`, :mod:`posthoc`), which agree with R.

Bad input (a missing column, too few groups) raises ``ValueError`` with a
message that names the problem.
"""

from __future__ import annotations

from dataclasses import asdict
from itertools import combinations

import pandas as pd

from hcss.analysis import posthoc, r_distributions, repeated
from hcss.analysis import stats as tests
from hcss.analysis.stats import MannWhitneyMethod, TestResult

RESULT_COLUMNS = (
    "statistic_name",
    "statistic",
    "df",
    "p",
    "n",
    "effect_name",
    "effect_size",
    "effect_lower",
    "effect_upper",
    "interval_method",
    "method",
    "note",
)
PAIR_COLUMNS = ("group_a", "group_b", "difference", "lower", "upper", "statistic", "p")


def _require(data: pd.DataFrame, *columns: str) -> None:
    missing = [column for column in columns if column not in data.columns]
    if missing:
        raise ValueError(f"data has no column(s) {', '.join(missing)}")


def _row(result: TestResult, **keys: object) -> dict[str, object]:
    fields = asdict(result)
    return {**keys, **{column: fields[column] for column in RESULT_COLUMNS}}


def _groups(data: pd.DataFrame, dv: str, between: str) -> dict[str, list[float]]:
    _require(data, dv, between)
    return {
        str(level): pd.to_numeric(rows[dv], errors="coerce").dropna().tolist()
        for level, rows in data.groupby(between, sort=True)
    }


def _blocks(data: pd.DataFrame, dv: str, within: str, subject: str) -> pd.DataFrame:
    _require(data, dv, within, subject)
    wide = data.pivot_table(index=subject, columns=within, values=dv, aggfunc="mean")
    wide.columns = [str(column) for column in wide.columns]
    return wide


def kruskal(data: pd.DataFrame, dv: str, between: str) -> pd.DataFrame:
    """Kruskal-Wallis H test across the levels of ``between``, as R's ``kruskal.test``.

    Parameters
    ----------
    data : pandas.DataFrame
        Long format: one row per unit.
    dv : str
        Column of the values.
    between : str
        Column naming each unit's group.

    Returns
    -------
    pandas.DataFrame
        One row: ``statistic_name`` ("H"), ``statistic``, ``df``, ``p``, ``n``,
        ``effect_name`` ("ε²" = H/(n − 1)), ``effect_size``, ``effect_lower`` and
        ``effect_upper`` (95% percentile bootstrap, seeded), ``interval_method``,
        ``method`` (χ² approximation, tie-corrected), ``note``.
    """
    return pd.DataFrame([_row(tests.kruskal_wallis(_groups(data, dv, between)))])


def mann_whitney(
    data: pd.DataFrame,
    dv: str,
    between: str,
    method: MannWhitneyMethod = "auto",
    continuity: bool = True,
) -> pd.DataFrame:
    """Two-sided Mann-Whitney-Wilcoxon test of the two levels of ``between``, as ``wilcox.test``.

    Returns
    -------
    pandas.DataFrame
        One row: ``group_a``, ``group_b`` (sorted levels; W is ``group_a``'s
        U₁ as R prints it), ``U`` = min(U₁, U₂), then the columns of
        :func:`kruskal` with ``effect_name`` "rank-biserial r" (positive when
        ``group_a`` tends to be larger) and a Fisher-z interval; ``method``
        says exact or normal, and why.
    """
    groups = _groups(data, dv, between)
    if len(groups) != 2:
        raise ValueError(f"{between!r} must have exactly two levels, found {len(groups)}")
    (a, first), (b, second) = groups.items()
    result = tests.mann_whitney(first, second, method, continuity)
    u = tests.mann_whitney_u(result, len(first), len(second))
    return pd.DataFrame([_row(result, group_a=a, group_b=b, U=u)])


def paired_wilcoxon(data: pd.DataFrame, dv: str, within: str, subject: str) -> pd.DataFrame:
    """Wilcoxon signed-rank tests of every pair of ``within`` levels, as paired ``wilcox.test``.

    Subjects missing either level of a pair are left out of that pair.

    Returns
    -------
    pandas.DataFrame
        One row per pair: ``group_a``, ``group_b`` (V is over ``group_a − group_b``),
        the columns of :func:`kruskal` with ``statistic_name`` "V",
        ``effect_name`` "matched-pairs rank-biserial r" and its Fisher-z
        interval, and ``p_holm``: Holm-adjusted over the pairs returned.
    """
    wide = _blocks(data, dv, within, subject)
    if wide.shape[1] < 2:
        raise ValueError(f"{within!r} needs at least two levels")
    rows = []
    for a, b in combinations(wide.columns, 2):
        pair = wide[[a, b]].dropna()
        rows.append(_row(repeated.paired_wilcoxon(pair[a], pair[b]), group_a=a, group_b=b))
    frame = pd.DataFrame(rows)
    frame["p_holm"] = r_distributions.holm(frame["p"].tolist())
    return frame


def friedman(data: pd.DataFrame, dv: str, within: str, subject: str) -> pd.DataFrame:
    """Friedman's test over the ``within`` levels, subjects with every level, as ``friedman.test``.

    Returns
    -------
    pandas.DataFrame
        One row: the columns of :func:`kruskal` with ``statistic_name`` "χ²",
        ``effect_name`` "Kendall's W" and a percentile bootstrap interval
        over subjects (seeded).
    """
    return pd.DataFrame([_row(repeated.friedman(_blocks(data, dv, within, subject)))])


def _pairs(comparison: posthoc.PairwiseComparison) -> pd.DataFrame:
    frame = pd.DataFrame([asdict(row) for row in comparison.rows], columns=list(PAIR_COLUMNS))
    return frame.assign(statistic_name=comparison.statistic_name, note=comparison.note)


def tukey_kramer(data: pd.DataFrame, dv: str, between: str) -> pd.DataFrame:
    """Tukey-Kramer comparisons of Kruskal-Wallis mean ranks (MATLAB's ``multcompare``).

    Returns
    -------
    pandas.DataFrame
        One row per pair: ``group_a``, ``group_b``, ``difference`` of mean
        ranks with its simultaneous 95% ``lower``/``upper`` bounds,
        ``statistic`` (q), ``p`` (studentized range), ``statistic_name``, ``note``.
    """
    return _pairs(posthoc.tukey_kramer_ranks(_groups(data, dv, between)))


def tukey_hsd(data: pd.DataFrame, dv: str, between: str) -> pd.DataFrame:
    """Tukey HSD on the raw values, as R's ``TukeyHSD(aov(dv ~ between))``.

    Returns
    -------
    pandas.DataFrame
        One row per pair, as :func:`tukey_kramer`, with differences of means.
    """
    return _pairs(posthoc.tukey_hsd(_groups(data, dv, between)))


def dunn(data: pd.DataFrame, dv: str, between: str) -> pd.DataFrame:
    """Dunn's z test on mean ranks with Holm's adjustment.

    Returns
    -------
    pandas.DataFrame
        One row per pair, as :func:`tukey_kramer`, with ``statistic`` z and
        Holm-adjusted ``p``.
    """
    return _pairs(posthoc.dunn_holm(_groups(data, dv, between)))


def spearman(data: pd.DataFrame, x: str, y: str) -> pd.DataFrame:
    """Spearman's ρ of two columns with R's default p (exact, Edgeworth or t).

    Returns
    -------
    pandas.DataFrame
        One row: the columns of :func:`kruskal` with ``statistic_name`` "ρ",
        ``df`` = n − 2, the interval by Fisher z (Bonett-Wright SE) and
        ``method`` naming how p was computed.
    """
    _require(data, x, y)
    result = tests.spearman(
        pd.to_numeric(data[x], errors="coerce"), pd.to_numeric(data[y], errors="coerce")
    )
    return pd.DataFrame([_row(result, x=x, y=y)])
