"""Analysis of a parameter sweep (`hcss simulate sweep`): a table per cell, heat maps per pair.

For every cell (combination of swept values) and model: success rate overall,
on easy and on difficult decisions (the mean over trials of each trial's share
of correct decisions, as in the simulation-only experiment's summary) and
mean decision time in minutes (over decisions). For every pair of swept
parameters, one figure of heat maps: a row per model, columns success easy,
success difficult and decision time; parameters not in the pair are averaged
over. A sweep of one parameter gets one figure with that parameter alone.
"""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from hcss.analysis.tables import write_checked
from hcss.tablespec import SWEEP_DECISIONS
from hcss.tablespec.analysis import SWEEP_CELLS
from hcss.tablespec.frames import ContractError, check

MANIFEST = "sweep.json"
SPLITS = ("overall", "easy", "difficult")
#: The columns of a sweep's decisions the cell table reads, besides the parameters'.
READ_COLUMNS = ("model", "trial_id", "difficulty", "correct", "decision_time_s")
PANELS = (
    ("success_easy", "success rate, easy"),
    ("success_difficult", "success rate, difficult"),
    ("decision_time_min", "decision time (min)"),
)


class SweepInputError(ValueError):
    """The directory is not a readable sweep output."""


def is_sweep(path: Path) -> bool:
    return Path(path).is_dir() and (Path(path) / MANIFEST).is_file()


def load_sweep(path: Path) -> tuple[list[str], pd.DataFrame]:
    """The swept parameter names and the decisions table of a sweep directory."""
    path = Path(path)
    try:
        manifest = json.loads((path / MANIFEST).read_text(encoding="utf-8"))
        names = list(manifest["parameters"])
        decisions = pd.read_csv(path / "decisions.csv")
    except (OSError, ValueError, KeyError, TypeError) as error:
        raise SweepInputError(f"{path} is not a complete sweep output: {error}") from None
    missing = [c for c in [*names, *READ_COLUMNS] if c not in decisions]
    if missing or decisions.empty:
        raise SweepInputError(f"{path}/decisions.csv lacks {missing or 'rows'}")
    try:  # the columns read keep their contract (hcss.tablespec.SWEEP_DECISIONS)
        check(decisions, SWEEP_DECISIONS, READ_COLUMNS)
    except ContractError as error:
        raise SweepInputError(f"{path}/decisions.csv: {error}") from None
    decisions["correct"] = decisions["correct"].astype(str).str.lower().isin(["true", "1"])
    return names, decisions


def cell_table(decisions: pd.DataFrame, names: list[str]) -> pd.DataFrame:
    """One row per cell and model: trials, decisions, success per split, decision time."""
    keys = [*names, "model"]
    out = decisions.groupby(keys, sort=True).agg(
        trials=("trial_id", "nunique"),
        decisions=("trial_id", "size"),
        decision_time_min=("decision_time_s", lambda s: float(np.mean(s)) / 60.0),
    )
    for split in SPLITS:
        chosen = decisions if split == "overall" else decisions[decisions["difficulty"] == split]
        per_trial = chosen.groupby([*keys, "trial_id"])["correct"].mean()
        out[f"success_{split}"] = per_trial.groupby(level=keys).mean()
    columns = ["trials", "decisions", *(f"success_{s}" for s in SPLITS), "decision_time_min"]
    return out[columns].reset_index()


@dataclass
class SweepReport:
    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)


def heatmap(table: pd.DataFrame, x: str, y: str | None, path: Path) -> Path:
    """Heat maps of the PANELS, a row per model, over parameters x (and y)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    models = sorted(table["model"].unique())
    fig, axes = plt.subplots(
        len(models), len(PANELS), figsize=(4.2 * len(PANELS), 3.2 * len(models)), squeeze=False
    )
    for row, model in enumerate(models):
        mine = table[table["model"] == model]
        for col, (measure, title) in enumerate(PANELS):
            ax = axes[row][col]
            index = [y] if y else []
            grid = mine.groupby([*index, x])[measure].mean()
            grid = grid.unstack(x) if y else grid.to_frame().T
            values = grid.to_numpy(dtype=float)
            is_rate = measure.startswith("success")
            image = ax.imshow(
                values,
                origin="lower",
                aspect="auto",
                cmap="viridis" if is_rate else "magma_r",
                vmin=0.0 if is_rate else None,
                vmax=1.0 if is_rate else None,
            )
            for (i, j), value in np.ndenumerate(values):
                if np.isfinite(value):
                    shade = image.norm(value)  # dark cells get white figures
                    dark = shade < 0.6 if is_rate else shade > 0.45
                    ax.text(
                        j,
                        i,
                        f"{value:.2f}",
                        ha="center",
                        va="center",
                        fontsize=8,
                        color="white" if dark else "black",
                    )
            ax.set_xticks(
                range(values.shape[1]),
                [f"{v:g}" if isinstance(v, float) else str(v) for v in grid.columns],
            )
            ax.set_yticks(range(values.shape[0]), [str(v) for v in grid.index] if y else [""])
            ax.set_xlabel(x)
            if y:
                ax.set_ylabel(y)
            ax.set_title(f"{model}: {title}", fontsize=10)
            fig.colorbar(image, ax=ax, shrink=0.8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def analyse_sweep(path: Path, out: Path) -> SweepReport:
    """Write tables/sweep_cells.{csv,md} and figures/sweep_<x>__<y>.png into OUT."""
    names, decisions = load_sweep(path)
    table = cell_table(decisions, names)
    report = SweepReport()
    tables = Path(out) / "tables"
    tables.mkdir(parents=True, exist_ok=True)
    csv_path = tables / "sweep_cells.csv"
    write_checked(csv_path, table, SWEEP_CELLS)
    md_path = tables / "sweep_cells.md"
    md_path.write_text(_markdown(table), encoding="utf-8")
    report.tables += [csv_path, md_path]
    pairs: list[tuple[str, str | None]] = [*itertools.combinations(names, 2)] or [(names[0], None)]
    for x, y in pairs:
        name = f"sweep_{x}" + (f"__{y}" if y else "") + ".png"
        report.figures.append(heatmap(table, x, y, Path(out) / "figures" / name))
    return report


def _markdown(table: pd.DataFrame) -> str:
    header = "| " + " | ".join(table.columns) + " |"
    rule = "|" + "---|" * len(table.columns)
    lines = [header, rule]
    for row in table.itertuples(index=False):
        cells = [f"{v:.3f}" if isinstance(v, float) else str(v) for v in row]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
