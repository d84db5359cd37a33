"""`hcss export` does only the export's work: reading a study file to export its
participants checks the file's settings without building the MRT's figures (5.6 s of a
cold `hcss export`; the console's export, in a warm server, had them built already)."""

from __future__ import annotations

import subprocess
import sys

from tests.support.study import new_participant, visitor

RUN = """
import sys
from hcss.cli import main
from hcss.questionnaires.mrt import items
try:
    main(sys.argv[1:])
except SystemExit as done:
    print("exit", done.code)
print("mrt figures built:", bool(items._bank._built))
"""


def test_hcss_export_reads_the_study_file_without_building_the_mrt_figures(
    demo_app, database_url, tmp_path
) -> None:
    guest = visitor(demo_app, new_participant(demo_app))
    guest.submit({"decision": "agree"})  # at demographics: a participant of the demo study
    run = subprocess.run(
        [sys.executable, "-c", RUN, "export", str(tmp_path / "e"), "--database-url", database_url],
        capture_output=True,
        text=True,
        check=False,
    )
    assert "exported 1 participants" in run.stdout, run.stdout + run.stderr
    assert "exit 0" in run.stdout
    assert "mrt figures built: False" in run.stdout


def test_hcss_export_imports_no_compiled_simulation(demo_app, database_url, tmp_path) -> None:
    """An export runs no simulation: importing the model's numba kernels (and compiling or
    loading them) cost a cold `hcss export` over a second that the console's warm zip of
    the same database never pays."""
    guest = visitor(demo_app, new_participant(demo_app))
    guest.submit({"decision": "agree"})
    run = subprocess.run(
        [
            sys.executable,
            "-X",
            "importtime",
            "-c",
            "from hcss.cli import main; main()",
            "export",
            str(tmp_path / "e"),
            "--database-url",
            database_url,
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    assert "exported 1 participants" in run.stdout, run.stdout + run.stderr[-2000:]
    imported = {
        line.rsplit("|", 1)[-1].strip()
        for line in run.stderr.splitlines()
        if line.startswith("import time:") and "|" in line
    }
    assert "hcss.platform.export.writer" in imported
    assert not {"numba", "hcss.simulation.world", "hcss.simulation.engine"} & imported
