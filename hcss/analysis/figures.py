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
from matplotlib.axes import Axes
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
#: Fewer values than this are drawn as coloured dots, not a box.
MIN_BOX_VALUES = 3


def _ordered_groups(chosen: pd.DataFrame) -> list[str]:
    """Models in display order, then any other group (e.g. "All" for the MRT, met once)."""
    present = set(chosen["group"])
    return [g for g in GROUP_ORDER if g in present] + sorted(present - set(GROUP_ORDER))


def _draw_boxes(axes: Axes, chosen: pd.DataFrame, rng: np.random.Generator) -> list[str]:
    """Boxes per model (colour) within each split (position), each unit a jittered dot."""
    groups = _ordered_groups(chosen)
    splits = [split for split in SPLITS if split in set(chosen["split"])]
    width = 0.8 / max(len(groups), 1)
    for split_index, split in enumerate(splits):
        for group_index, group in enumerate(groups):
            values = chosen[(chosen["split"] == split) & (chosen["group"] == group)]["value"]
            values = values.dropna().to_numpy()
            if not len(values):
                continue
            position = split_index + (group_index - (len(groups) - 1) / 2) * width
            if len(values) < MIN_BOX_VALUES:  # a box of one or two values says nothing
                axes.scatter(
                    np.full(len(values), position),
                    values,
                    s=45,
                    color=GROUP_COLOURS.get(group, "#cccccc"),
                    edgecolor="black",
                    zorder=3,
                )
                continue
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


def _legend(axes: Axes, groups: list[str]) -> None:
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
    groups = _ordered_groups(chosen)
    splits = [split for split in SPLITS if split in set(chosen["split"])]
    figure, axes = plt.subplots(figsize=(2.2 + 1.1 * len(groups) * len(splits) / 2, 4.0))
    _legend(axes, _draw_boxes(axes, chosen, np.random.default_rng(0)))
    _fix_range(axes, measure)
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
        _fix_range(panel, measure)
        panel.set_title(measure_label(measure), fontsize="small")
    for panel in list(axes.flat)[len(members) :]:
        panel.set_visible(False)
    _legend(axes.flat[0], groups)
    figure.suptitle(title)
    figure.tight_layout()
    return figure


#: Measures that are proportions or percentages: their axis shows the whole range.
RATE_RANGES = {"success_rate": (0.0, 1.0)}
PERCENT_PREFIXES = ("sa_", "collective_observations", "target_observations")


def measure_range(measure: str) -> tuple[float, float] | None:
    """The fixed axis range of a rate (0–1) or percentage (0–100), else None."""
    if measure in RATE_RANGES:
        return RATE_RANGES[measure]
    if measure.startswith(PERCENT_PREFIXES):
        return (0.0, 100.0)
    return None


def _fix_range(axes: Axes, measure: str) -> None:
    bounds = measure_range(measure)
    if bounds:
        margin = 0.03 * (bounds[1] - bounds[0])
        axes.set_ylim(bounds[0] - margin, bounds[1] + margin)


def _profile_panels(members: list[str]) -> list[tuple[str, list[str]]]:
    """Scales of one kind per panel: NASA-TLX totals, ratings and weighted scores differ in range."""
    kinds = {
        "Totals (0–100)": [m for m in members if m.endswith((".overall", ".raw_tlx"))],
        "Subscale ratings (0–100)": [m for m in members if m.endswith("_rating")],
        "Weighted subscales (rating × weight ÷ 15)": [
            m for m in members if m.endswith("_weighted")
        ],
    }
    if (
        not kinds["Subscale ratings (0–100)"]
        and not kinds["Weighted subscales (rating × weight ÷ 15)"]
    ):
        return [("", members)]
    return [(title, chosen) for title, chosen in kinds.items() if chosen]


def _scale_label(measure: str) -> str:
    label = measure_label(measure).partition(": ")[2] or measure
    return label.removesuffix(" rating").removesuffix(" weighted")


def profile_figure(measures: pd.DataFrame, members: list[str], title: str) -> Figure:
    """Mean ± SE of each scale per model, as dots grouped by scale (no lines between scales).

    Scales are separate quantities, so nothing joins them; NASA-TLX totals,
    ratings and weighted scores get a panel each because their ranges differ.
    """
    chosen = measures[measures["measure"].isin(members) & (measures["split"] == "overall")]
    groups = _ordered_groups(chosen)
    panels = _profile_panels(members)
    widths = [max(2.0, 0.7 * len(scales) + 1.0) for _, scales in panels]
    figure, axes_row = plt.subplots(
        1,
        len(panels),
        figsize=(sum(widths) + 1.5, 4.4),
        squeeze=False,
        gridspec_kw={"width_ratios": widths},
    )
    for axes, (panel_title, scales) in zip(axes_row[0], panels, strict=True):
        positions = np.arange(len(scales))
        for index, group in enumerate(groups):
            rows = chosen[chosen["group"] == group].groupby("measure")["value"]
            summary = rows.agg(["mean", "sem"]).reindex(scales)
            offset = (index - (len(groups) - 1) / 2) * 0.18
            axes.errorbar(
                positions + offset,
                summary["mean"],
                yerr=summary["sem"],
                marker="o",
                linestyle="none",
                capsize=3,
                label=group,
                color=GROUP_COLOURS.get(group, "#555555"),
            )
        axes.set_xticks(
            positions, [_scale_label(m) for m in scales], rotation=35, ha="right", fontsize="small"
        )
        axes.set_xlim(-0.6, len(scales) - 0.4)
        if "(0–100)" in panel_title:
            axes.set_ylim(-3, 103)
        axes.set_title(panel_title, fontsize="small")
        axes.grid(axis="y", alpha=0.3)
    axes_row[0][0].set_ylabel("mean ± SE")
    axes_row[0][-1].legend(fontsize="small", title="model")
    figure.suptitle(title)
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
