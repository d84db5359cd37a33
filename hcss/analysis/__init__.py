"""Tidy exports in, the study's tables and figures out.

``load`` reads study exports and simulation decision tables, ``measures``
turns them into one value per unit (participant or scenario), ``stats`` and
``posthoc`` test them, ``builders``/``tables``/``figures`` present them and
``report`` runs the whole chain for ``hcss analyze``. Nothing here imports
Flask: the analyst needs only the exported files.

The tests themselves are public, long-format DataFrame in, tidy DataFrame
out, for use in a notebook without the report::

    from hcss.analysis import kruskal, paired_wilcoxon
    kruskal(frame, dv="success_rate", between="model")
    paired_wilcoxon(frame, dv="success_rate", within="model", subject="participant")
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hcss.analysis.api import (
        dunn,
        friedman,
        kruskal,
        mann_whitney,
        paired_wilcoxon,
        spearman,
        tukey_hsd,
        tukey_kramer,
    )

__all__ = [
    "dunn",
    "friedman",
    "kruskal",
    "mann_whitney",
    "paired_wilcoxon",
    "spearman",
    "tukey_hsd",
    "tukey_kramer",
]


def __getattr__(name: str) -> Any:
    """Load the test API on first use: ``hcss simulate`` imports the package for its summary
    and should not pay for statsmodels and scikit-posthocs."""
    if name in __all__:
        from hcss.analysis import api

        return getattr(api, name)
    raise AttributeError(f"module 'hcss.analysis' has no attribute {name!r}")
