"""Descriptive statistics per measure, group and split.

The study reports each measure as mean (SD) and median (min–max) per model;
the SD is the sample SD (n − 1), as R's ``sd`` and SPSS report it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict

import numpy as np
import pandas as pd

from hcss.study_units import Summary
from hcss.tablespec.analysis import DESCRIPTIVE


def summarise(values: Sequence[float] | np.ndarray) -> Summary:
    """Summary of the non-missing values; SD is NaN for a single value."""
    array = np.asarray(values, dtype=float)
    return Summary.of(array[~np.isnan(array)].tolist())


def descriptive_frame(measures: pd.DataFrame) -> pd.DataFrame:
    """One row per (measure, group, split) with n, mean, sd, median, minimum, maximum."""
    rows = []
    for (measure, group, split), subset in measures.groupby(
        ["measure", "group", "split"], sort=False
    ):
        rows.append(
            {"measure": measure, "group": group, "split": split}
            | asdict(summarise(subset["value"]))
        )
    return pd.DataFrame(rows, columns=list(DESCRIPTIVE.names))
