"""The study's comparison figure: one measure per model, Overall/Easy/Difficult.

Box plots rather than bars of means, because the tests are rank-based and a
box shows the median and spread they compare; the mean is marked too, since
the tables report it. Simulation-only models are hatched, so the reader sees
at a glance which boxes had no human in the loop.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # no display on servers or in tests; must precede pyplot

import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402
from matplotlib.patches import Patch  # noqa: E402

from hcss.analysis.decision_measures import SPLITS  # noqa: E402
from hcss.analysis.load import GROUP_ORDER  # noqa: E402
from hcss.analysis.measures import measure_label  # noqa: E402

GROUP_COLOURS = {
    "M1SIM": "#9ecae1",
    "M2SIM": "#fdae6b",
    "M1": "#3182bd",
    "M2": "#e6550d",
    "M3": "#31a354",
}
SPLIT_LABELS = {"overall": "Overall", "easy": "Easy", "difficult": "Difficult"}


def comparison_figure(measures: pd.DataFrame, measure: str) -> Figure:
    """Box plot of ``measure`` per model (colour) within each split (position)."""
    chosen = measures[measures["measure"] == measure]
    groups = [group for group in GROUP_ORDER if group in set(chosen["group"])]
    splits = [split for split in SPLITS if split in set(chosen["split"])]
    figure, axes = plt.subplots(figsize=(2.2 + 1.1 * len(groups) * len(splits) / 2, 4.0))
    width = 0.8 / max(len(groups), 1)
    for split_index, split in enumerate(splits):
        for group_index, group in enumerate(groups):
            values = chosen[(chosen["split"] == split) & (chosen["group"] == group)]["value"]
            values = values.dropna().to_numpy()
            if not len(values):
                continue
            position = split_index + (group_index - (len(groups) - 1) / 2) * width
            boxes = axes.boxplot(
                values,
                positions=[position],
                widths=width * 0.85,
                patch_artist=True,
                showmeans=True,
                meanprops={"marker": "D", "markerfacecolor": "white", "markeredgecolor": "black"},
                medianprops={"color": "black"},
            )
            for box in boxes["boxes"]:
                box.set_facecolor(GROUP_COLOURS.get(group, "#cccccc"))
                if group.endswith("SIM"):
                    box.set_hatch("//")
    axes.set_xticks(range(len(splits)), [SPLIT_LABELS[split] for split in splits])
    axes.set_xlim(-0.6, len(splits) - 0.4)
    axes.set_ylabel(measure_label(measure))
    axes.set_title(f"{measure_label(measure)} per model")
    mean_marker = Line2D(
        [], [], marker="D", linestyle="", markerfacecolor="white", color="black", label="mean"
    )
    axes.legend(
        handles=[
            Patch(
                facecolor=GROUP_COLOURS.get(group, "#cccccc"),
                hatch="//" if group.endswith("SIM") else "",
                label=group,
            )
            for group in groups
        ]
        + [mean_marker],
        loc="best",
        fontsize="small",
    )
    axes.grid(axis="y", alpha=0.3)
    figure.tight_layout()
    return figure


def write_figure(figure: Figure, directory: Path, name: str) -> list[Path]:
    """Save as SVG and PNG and release the figure's memory."""
    directory.mkdir(parents=True, exist_ok=True)
    paths = [directory / f"{name}.svg", directory / f"{name}.png"]
    figure.savefig(paths[0])
    figure.savefig(paths[1], dpi=150)
    plt.close(figure)
    return paths
