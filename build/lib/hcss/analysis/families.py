"""The paper's measure families, in the paper's order.

A family is what the paper prints in one table and one figure: e.g. the four
request frequencies together, or every NASA-TLX scale (weighted components,
raw ratings and both totals) in one table instead of one table per scale.
Each family names the measures it needs by key or prefix, so a table is
built only from what it needs: an export without decisions still has every
questionnaire, probe and MRT family.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from hcss.analysis.measures import measure_order


@dataclass(frozen=True)
class Family:
    """A named group of measures shown together."""

    key: str
    title: str
    measures: tuple[str, ...] = ()
    prefix: str = ""
    profile: bool = False  # drawn as a profile of means (questionnaire scales)

    def members(self, measures: pd.DataFrame) -> list[str]:
        """The family's measures present in ``measures``, in display order."""
        present = set(measures["measure"])
        if self.prefix:
            chosen = [name for name in present if name.startswith(self.prefix)]
        else:
            chosen = [name for name in self.measures if name in present]
        return sorted(chosen, key=_scale_order if self.prefix else measure_order)


_SCALE_ORDER = ("overall", "raw_tlx", "SU", "DAR", "SAR")


def _scale_order(measure: str) -> tuple[int, str]:
    """Totals first (in the paper's order), then scales alphabetically."""
    scale = measure.partition(".")[2]
    rank = _SCALE_ORDER.index(scale) if scale in _SCALE_ORDER else len(_SCALE_ORDER)
    return (rank, scale)


FAMILIES = (
    Family("performance", "Success rate and decision time", ("success_rate", "decision_time_min")),
    Family(
        "requests",
        "Requests per decision per minute",
        ("request_frequency", "investigate_frequency", "decide_frequency", "abandon_frequency"),
    ),
    Family("interventions", "Interventions", ("interventions",)),
    Family(
        "observations",
        "Collective and target observations",
        ("collective_observations", "target_observations"),
    ),
    Family(
        "sa_probes", "SA probes by level", ("sa_overall", "sa_level1", "sa_level2", "sa_level3")
    ),
    Family("nasa_tlx", "NASA-TLX (weighted, raw, subscales)", prefix="nasa_tlx.", profile=True),
    Family("sart", "SART (SU, DAR, SAR, total)", prefix="sart.", profile=True),
    Family(
        "post_trial", "Post-trial questionnaire (Likert 1–7)", prefix="post_trial.", profile=True
    ),
    Family("ranking", "Post-experiment ranking (1 = best)", prefix="ranking.", profile=True),
    Family("mrt", "Mental Rotations Test", prefix="mrt."),
)
