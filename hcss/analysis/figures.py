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

import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from hcss.analysis.decision_measures import SPLITS
from hcss.analysis.load import GROUP_ORDER
from hcss.analysis.measures import measure_label

GROUP_COLOURS = {
    "M1SIM": "#9ecae1",
    "M2SIM": "#fdae6b",
    "M1": "#3182bd",
    "M2": "#e6550d",
    "M3": "#31a354",
}
SPLIT_LABELS = {"overall": "Overall", "easy": "Easy", "difficult": "Difficult"}


def _draw_boxes(axes, chosen: pd.DataFrame, rng: np.random.Generator) -> list[str]:
    """Boxes per model (colour) within each split (position), each unit a jittered dot."""
    groups = [group for group in GROUP_ORDER if group in set(chosen["group"])]
    splits = [split for split in SPLITS if split in set(chosen["split"])]
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
                showfliers=False,
                meanprops={"marker": "D", "markerfacecolor": "white", "markeredgecolor": "black"},
                medianprops={"color": "black"},
            )
            for box in boxes["boxes"]:
                box.set_facecolor(GROUP_COLOURS.get(group, "#cccccc"))
                if group.endswith("SIM"):
                    box.set_hatch("//")
            jitter = rng.uniform(-width * 0.25, width * 0.25, len(values))
            axes.scatter(position + jitter, values, s=8, color="black", alpha=0.5, zorder=3)
    axes.set_xticks(range(len(splits)), [SPLIT_LABELS[split] for split in splits])
    axes.set_xlim(-0.6, len(splits) - 0.4)
    axes.grid(axis="y", alpha=0.3)
    return groups


def _legend(axes, groups: list[str]) -> None:
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


def comparison_figure(measures: pd.DataFrame, measure: str) -> Figure:
    """Box and strip plot of ``measure`` per model (colour) within each split (position)."""
    chosen = measures[measures["measure"] == measure]
    groups = [group for group in GROUP_ORDER if group in set(chosen["group"])]
    splits = [split for split in SPLITS if split in set(chosen["split"])]
    figure, axes = plt.subplots(figsize=(2.2 + 1.1 * len(groups) * len(splits) / 2, 4.0))
    _legend(axes, _draw_boxes(axes, chosen, np.random.default_rng(0)))
    axes.set_ylabel(measure_label(measure))
    axes.set_title(f"{measure_label(measure)} per model")
    figure.tight_layout()
    return figure


def family_figure(measures: pd.DataFrame, members: list[str], title: str) -> Figure:
    """One box-and-strip panel per measure of a family, side by side."""
    columns = min(len(members), 4)
    rows = -(-len(members) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(3.6 * columns, 3.4 * rows), squeeze=False)
    rng = np.random.default_rng(0)
    groups: list[str] = []
    for panel, measure in zip(axes.flat, members, strict=False):
        groups = _draw_boxes(panel, measures[measures["measure"] == measure], rng) or groups
        panel.set_title(measure_label(measure), fontsize="small")
    for panel in list(axes.flat)[len(members) :]:
        panel.set_visible(False)
    _legend(axes.flat[0], groups)
    figure.suptitle(title)
    figure.tight_layout()
    return figure


def profile_figure(measures: pd.DataFrame, members: list[str], title: str) -> Figure:
    """Mean ± standard error of each scale per model: a questionnaire's profile."""
    chosen = measures[measures["measure"].isin(members) & (measures["split"] == "overall")]
    groups = [group for group in GROUP_ORDER if group in set(chosen["group"])]
    groups += sorted(set(chosen["group"]) - set(groups))
    figure, axes = plt.subplots(figsize=(max(5.0, 0.6 * len(members) + 2.5), 4.2))
    positions = np.arange(len(members))
    for index, group in enumerate(groups):
        stats = chosen[chosen["group"] == group].groupby("measure")["value"].agg(["mean", "sem"])
        stats = stats.reindex(members)
        offset = (index - (len(groups) - 1) / 2) * 0.08
        axes.errorbar(
            positions + offset,
            stats["mean"],
            yerr=stats["sem"],
            marker="o",
            capsize=3,
            label=group,
            color=GROUP_COLOURS.get(group, "#555555"),
        )
    labels = [measure_label(measure).partition(": ")[2] or measure for measure in members]
    axes.set_xticks(positions, labels, rotation=35, ha="right", fontsize="small")
    axes.set_ylabel("mean ± SE")
    axes.set_title(title)
    axes.grid(axis="y", alpha=0.3)
    axes.legend(fontsize="small")
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
