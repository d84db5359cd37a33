"""One data contract per table: every table hcss writes or reads, declared once.

A :class:`TableSpec` names a table's columns in order, each with its type,
its missing-value rule and its meaning. The study export, the simulation's
outputs (an experiment's and a sweep's decisions, the equivalence reference,
a calibration's trials) and the analysis's loaders take their columns from
here, every CSV is written by `hcss.tidy_csv`, and the data dictionary is
rendered from these specs (`hcss.tablespec.dictionary`). Frames are checked
against a spec with pandera in `hcss.tablespec.frames`, which only readers
of frames import.

A leaf: it imports nothing else of hcss, so the model, the platform and the
analysis may all read it.
"""

from hcss.tablespec.decisions import DECISIONS
from hcss.tablespec.export import EXPORT_TABLES
from hcss.tablespec.simulation import (
    CALIBRATION_TRIALS,
    EQUIVALENCE_REFERENCE,
    SIMULATION_TABLES,
    SWEEP_DECISIONS,
)
from hcss.tablespec.spec import Column, Dtype, TableSpec

__all__ = [
    "CALIBRATION_TRIALS",
    "DECISIONS",
    "EQUIVALENCE_REFERENCE",
    "EXPORT_TABLES",
    "SIMULATION_TABLES",
    "SWEEP_DECISIONS",
    "Column",
    "Dtype",
    "TableSpec",
]
