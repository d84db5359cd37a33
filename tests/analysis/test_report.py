"""`hcss analyze` end to end on the three inputs a researcher has, each a complete report.

(a) a simulation-only experiment's output plus a bot export (the bot contributes
nothing once bots are excluded, and the report says so), (b) a bot export whose
trials have no completed decision, (c) the console's zip as downloaded. The bot
export is made once per module by a participant bot walking the demo study.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pandas as pd
import pytest
from click.testing import CliRunner

from hcss.analysis.cli import analyze
from hcss.platform.bots.participant import bot_app, run_bots
from hcss.platform.export.archive import export_archive
from hcss.platform.export.writer import write_export
from tests.support.synthetic import simulation_decisions, write_table

# slow: one bot walk of the demo study (~10 s) for the module; any library warning that
# escapes to the terminal fails the test
pytestmark = [pytest.mark.slow, pytest.mark.filterwarnings("error")]

QUESTIONNAIRE_SECTIONS = ["sa_probes", "nasa_tlx", "sart", "post_trial", "ranking", "mrt"]


@pytest.fixture(scope="module")
def bot_export(tmp_path_factory) -> tuple[Path, Path]:
    """(export folder, console zip) of one bot's run through the demo study."""
    base = tmp_path_factory.mktemp("bot")
    app = bot_app(f"sqlite:///{base / 'db.sqlite'}", "demo", SECRET_KEY="t", TESTING=True)
    database = app.extensions["hcss_db"]
    try:
        database.create_all()
        run_bots(app, 1)
        with database.session_scope() as session:
            write_export(session, base / "export")
        buffer, name = export_archive(database, "tester")
    finally:
        database.engine.dispose()
    archive = base / name
    archive.write_bytes(buffer.getvalue())
    return base / "export", archive


def analyse(*arguments: str) -> tuple[str, list[str], str]:
    result = CliRunner().invoke(analyze, [*arguments, "--quiet"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    assert "Traceback" not in result.output
    # only the analysis's own warnings reach the terminal (library ones fail the test)
    assert all(line.startswith("Warning: ") for line in result.stderr.splitlines())
    out = Path(arguments[arguments.index("--out") + 1])
    page = (out / "report.html").read_text(encoding="utf-8")
    return page, re.findall(r"<section id='(\w+)'>", page), result.stderr


def assert_complete(page: str, sections: list[str], out: Path) -> None:
    """Contents lists every section; every table and figure the page names exists."""
    assert page.index('id="contents"') < page.index('id="inputs"')
    for key in sections:
        assert f"href='#{key}'" in page
    for name in re.findall(r"tables/(\w+)\.csv", page):
        for suffix in ("csv", "md", "tex"):
            assert (out / "tables" / f"{name}.{suffix}").stat().st_size > 0
    for name in re.findall(r'src="figures/(\w+)\.svg"', page):
        assert (out / "figures" / f"{name}.svg").read_text().startswith("<?xml")
        assert (out / "figures" / f"{name}.png").read_bytes().startswith(b"\x89PNG")


def test_a_simulation_experiment_plus_bot_export(bot_export, tmp_path):
    export, _ = bot_export
    write_table(simulation_decisions(scenarios=6, runs=2), tmp_path / "sim" / "decisions.csv")
    out = tmp_path / "report"
    page, sections, stderr = analyse(str(tmp_path / "sim"), str(export), "--out", str(out))
    assert sections == ["sample", "performance", "simulation", "study_tests", "correlations"]
    assert_complete(page, sections, out)
    # the bot export is named in a warning instead of vanishing
    assert f"Warning: {export.name} contributes nothing" in page  # no path in the report
    assert f"Warning: {export} contributes nothing" in stderr
    sample = pd.read_csv(out / "tables" / "sample.csv").set_index("row")["n"]
    assert sample["Excluded: bots"] == 1 and sample["Enrolled (real participants)"] == 0
    mann_whitney = pd.read_csv(out / "tables" / "mann_whitney.csv")
    assert (mann_whitney[["n_a", "n_b"]] == 6).all().all()
    assert (mann_whitney["U"] <= 18).all()  # min(U1, U2) <= n1 n2 / 2
    assert mann_whitney["note"].str.startswith("n < 10 in M1SIM, M2SIM").all()


def test_b_bot_export_without_decisions_still_gives_every_questionnaire_table(bot_export, tmp_path):
    export, _ = bot_export
    copy = tmp_path / "export"
    shutil.copytree(export, copy)
    decisions = pd.read_csv(copy / "decisions.csv")
    decisions.iloc[:0].to_csv(copy / "decisions.csv", index=False)  # header only
    (copy / "decisions.parquet").unlink()
    out = tmp_path / "report"
    page, sections, _ = analyse(str(copy), "--out", str(out), "--include-pilot")
    assert "performance" not in sections  # nothing to say without decisions ...
    assert ["sample", "observations", *QUESTIONNAIRE_SECTIONS] == [
        s for s in sections if s in ("sample", "observations", *QUESTIONNAIRE_SECTIONS)
    ]  # ... but every questionnaire, probe and MRT table is there, in the paper's order
    assert_complete(page, sections, out)
    assert "No completed decisions in the inputs." in page
    tlx = pd.read_csv(out / "tables" / "family_nasa_tlx.csv")
    scales = set(tlx["measure"])
    assert {"nasa_tlx.overall", "nasa_tlx.raw_tlx", "nasa_tlx.mental_demand_weighted"} <= scales
    assert "nasa_tlx.mental_demand_rating" in scales  # raw rating beside the weighted one
    sart = pd.read_csv(out / "tables" / "family_sart.csv")
    assert {"sart.SU", "sart.DAR", "sart.SAR", "sart.overall"} <= set(sart["measure"])


def test_c_console_zip_as_downloaded(bot_export, tmp_path):
    _, archive = bot_export
    out = tmp_path / "report"
    page, sections, stderr = analyse(str(archive), "--out", str(out), "--include-pilot")
    assert stderr == ""
    expected = ["sample", "performance", "requests", "observations", *QUESTIONNAIRE_SECTIONS]
    assert [s for s in sections if s in expected] == expected
    # one participant: the tests are listed once as not run, not printed as rows of n = 1
    assert not {"independent", "repeated"} & set(sections)
    assert "Friedman and paired Wilcoxon tests: 1 participant with every model" in page
    assert_complete(page, sections, out)
    assert f"<code>{archive.name}</code>" in page  # the inputs read, without the path
    assert str(archive.parent) not in page
    # the practice trials in the zip's training/ folder are not analysed
    measures = pd.read_csv(out / "measures.csv")
    assert set(measures["group"]) <= {"M1", "M2", "M3", "All"}
    for name in ("gee_success", "mixedlm_time", "friedman", "wilcoxon_paired"):
        assert not (out / "tables" / f"{name}.csv").exists(), name
    assert (out / "tables" / "attrition.csv").exists()
    assert 'id="demographics"' in page
